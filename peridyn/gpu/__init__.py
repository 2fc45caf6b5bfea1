"""Explicit runs on one NVIDIA GPU (``peridyn run --device gpu``): where the step's arrays live
on the device (:mod:`.placement`, over the device copies of :mod:`.state`), the binning of the
contact pair search on the device (:mod:`.pair_search`; the rest of contact is the CPU's, placed
on the device) and what has a GPU path (:mod:`.support`). The
step itself is the one of every target, :meth:`peridyn.solvers.explicit.verlet.Verlet.steps`; the models'
loop laws and the step's point laws are compiled for the GPU by the ``cuda`` backend
(:mod:`peridyn.kernels.numba_cuda`). Imported only by runs on the GPU."""
