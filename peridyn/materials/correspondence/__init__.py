"""Peridigm's classic correspondence (non-ordinary state-based) family: the per-point numerical core.

Numba kernels that follow PERIDIGM_CORRESPONDENCE.md §3-§7 operation by operation (left-to-right
sums, no FMA), so that results can be bit-identical with Peridigm's:

* :mod:`.tensor`: 3x3 tensor helpers (flat row-major 9-tuples), Inv3 and the Flanagan-Taylor kernel;
* :mod:`.kinematics`: shape tensor, deformation gradient, velocity gradient and the rotation update;
* :mod:`.stress`: the unrotated stress updates (elastic, J2, isotropic hardening, Needleman), the
  rotation back to the Cauchy stress and the first Piola-Kirchhoff stress times K^-1;
* :mod:`.forces`: force densities, Partial_Stress and the hourglass force, gathered per point.
"""
