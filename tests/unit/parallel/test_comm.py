"""What a process learns of an MPI launcher from its environment."""
import os
from unittest import mock

from peridyn.parallel.comm import launched_with_mpi, without_launcher


def test_without_launcher_drops_the_variables_of_mpi_launchers():
    env = {"PMI_SIZE": "2", "PMI_RANK": "1", "OMPI_COMM_WORLD_SIZE": "2", "HYDRA_CONTROL_FD": "9", "MPI_LOCALNRANKS": "2",
           "PMIX_RANK": "0", "PATH": "/bin", "PERIDYN_NO_PROGRESS": "1", "SLURM_JOB_ID": "7"}
    assert without_launcher(env) == {"PATH": "/bin", "PERIDYN_NO_PROGRESS": "1", "SLURM_JOB_ID": "7"}
    with mock.patch.dict(os.environ, env, clear=True):
        assert launched_with_mpi()
    with mock.patch.dict(os.environ, without_launcher(env), clear=True):
        assert not launched_with_mpi()
