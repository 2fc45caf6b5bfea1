"""The small-strain elastic constants a material reports (``Material.elastic_moduli``)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

#: how a material treats the model's dimension (``ElasticModuli.planar``)
Planar = Literal["3d", "plane strain", "plane stress"]


@dataclass(frozen=True)
class ElasticModuli:
    """The small-strain linear elastic constants of a material (``Material.elastic_moduli``),
    what models that need a material's stiffness read (``Critical Energy``, ``J_Integral``)
    instead of the material's own attributes. Moduli in M L^-1 T^-2 (Pa in SI).

    ``bulk`` is the bulk modulus K the material's force law uses: in a planar model
    (``planar`` not "3d") the in-plane (2D) bulk modulus, lambda + mu in plane strain and
    E / (2 (1 - nu)) in plane stress, as Peridigm's conversion of E and nu gives it.
    ``shear`` is the shear modulus mu (bond-based materials: the value their fixed Poisson's
    ratio implies, 3/5 K in 3D and K/2 in 2D). ``hookean`` is True when these constants alone
    give the material's small-strain stress, sigma = lambda tr(eps) I + 2 mu eps; False when
    they are the elastic part of a response that also depends on internal state or other fields
    (plasticity, viscoelasticity, fluid pressure). ``thickness`` (L) is the thickness (Height) of
    a planar model whose force law depends on it, else None; ``micromodulus`` is the pair
    stiffness c of a bond-based material (3D: M L^-5 T^-2; planar: per thickness), else None.
    """

    bulk: float
    shear: float
    planar: Planar = "3d"
    hookean: bool = True
    thickness: float | None = None
    micromodulus: float | None = None

    def youngs_and_poisson(self) -> tuple[float, float]:
        """(E, nu) of the Hooke law with these constants in the model's dimension (``planar``)."""
        K, mu = float(self.bulk), float(self.shear)
        if self.planar == "plane stress":  # K = E / (2 (1 - nu)), mu = E / (2 (1 + nu))
            return 4.0 * K * mu / (K + mu), (K - mu) / (K + mu)
        if self.planar == "plane strain":  # K = lambda + mu
            lam = K - mu
            return mu * (3 * lam + 2 * mu) / (lam + mu), lam / (2 * (lam + mu))
        return 9.0 * K * mu / (3.0 * K + mu), (3.0 * K - 2.0 * mu) / (2.0 * (3.0 * K + mu))
