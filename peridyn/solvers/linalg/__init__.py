"""The linear-algebra machinery the implicit solvers share (no solver plugin lives here):

* :mod:`.tangent` - the tangent stiffness K = d(f V)/dy (3x3-block BSR), its assembly from the
  materials, kinematic boundary conditions, products, under MPI stored by subdomain;
* :mod:`.coupled_tangent` - the 4x4-block tangent of the coupled (pressure) solve;
* :mod:`.linear` - the Krylov solvers (Peridigm's Belos CG, GMRES), reductions and the
  ``LinearSolver`` choice of method and preconditioner;
* :mod:`.aztecoo` - AztecOO's GMRES with its safeguards (NOXQuasiStatic);
* :mod:`.ilu` - ILU(0) on the tangent's pattern (AztecOO's "ilu" preconditioner);
* :mod:`.amg` - the algebraic multigrid preconditioner;
* :mod:`.guyan` - static (Guyan) condensation of a linear system onto master unknowns.

The solvers (``peridyn.solvers.implicit.quasistatic``, ``nox``, ``implicit``, ...) import these; these
import nothing of the solvers.
"""
