"""Test-session settings shared by every test folder.

GPU code runs under numba-cuda's simulator in the tests (CI has no GPU): the simulator must be
chosen before ``numba.cuda`` is first imported. A machine with a GPU runs the same tests on the
device with ``NUMBA_ENABLE_CUDASIM=0`` in the environment."""
import os
import sys

os.environ.setdefault("NUMBA_ENABLE_CUDASIM", "1")
if "numba" in sys.modules:
    sys.modules["numba"].config.reload_config()
