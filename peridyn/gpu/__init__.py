"""Explicit runs on one NVIDIA GPU (``peridyn run --device gpu``): the model on the device
(:mod:`.state`), the kernels of the Verlet step outside the bond loops (:mod:`.kernels`,
:mod:`.conditions`) and what has a GPU path (:mod:`.support`). The step itself is
:mod:`peridyn.solvers.verlet_gpu`; the models' loop laws are compiled for the GPU by the ``cuda``
backend (:mod:`peridyn.kernels.numba_cuda`). Imported only by runs on the GPU."""
