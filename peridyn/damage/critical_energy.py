"""``Critical Energy`` damage: bonds break when the energy they carry reaches the critical energy
release rate G0 of the material (docs/fracture.md).

The criterion is applied as a critical stretch s0 derived from G0 and the block's material with
the crossing-bond argument of Silling & Askari (2005, "A meshfree method based on the
peridynamic model of solid mechanics", Comput. Struct. 83, §3, eq. 26-27): G0 is the work needed
to break, at stretch s0, every bond that crosses a unit area of a plane,

    G0 = integral_0^delta dz  (energy of the bonds of a point at distance z that cross the plane)

evaluated per material:

The material is asked, not named: its ``bond_energy`` capability says which energy its bonds
store and ``elastic_moduli()`` gives the constants (peridyn.core.interfaces.Material), so a
plugin material that declares them is converted like the built-in one.

* ``bond_energy = "pair"``, e.g. ``Elastic Bond Based`` (micropotential w = c s^2 |xi| / 2 per pair):
    3D:               G0 = pi c s0^2 delta^5 / 10     -> s0 = sqrt(5 G0 / (9 K delta))
    2D (thickness h): G0 = c h s0^2 delta^4 / 4       -> plane stress s0 = sqrt(4 pi G0 / (9 E delta)),
                                                          plane strain s0 = sqrt(5 pi G0 / (12 E delta))
  (the 2D forms are Ha & Bobaru 2010, Int. J. Fract. 162, eq. 4); this is exactly "break a bond
  when its stored energy c s^2 |xi| / 2 exceeds the critical bond energy w0(xi) = c s0^2 |xi| / 2".
* ``bond_energy = "lps"``, e.g. ``Elastic`` (LPS, 3D): the same argument applied to the LPS energy written as
  W = (K - 5 mu/3) theta^2 / 2 + (15 mu / 2m) sum_j omega e^2 V_j, with the bonds crossing the
  plane at stretch s0 and theta from those bonds only, as Madenci & Oterkus (2014, "Peridynamic
  Theory and Its Applications", Springer, §4.? critical stretch of the ordinary state-based
  model) do for their omega = delta/|xi| model:

      G0 = s0^2 delta (A mu + B (K - 5 mu / 3)),
      A = (15/4) P5 / P4,  Pk = int_0^1 omega(r) r^k dr,
      B = int_0^1 g(a)^2 da,  g(a) = (3 / (2 P4)) int_a^1 omega(r) (r^4 - a r^3) dr

  (omega = 1: A = 25/8, B = 375/616; omega = delta/|xi|: A = 3, B = 26/45, and with
  K = 5 mu / 3 the bond-based value).
  B is computed exactly here, whereas Madenci & Oterkus approximate the dilatation term by
  (3/4)^4; see docs/fracture.md. Assumptions: uniform stretch of the crossing bonds, continuum
  (not discrete) weighted volume, a straight crack in the bulk.

Above s0 (strict, tension only, minus the thermal strain a_T dT_i when the model has a thermal
expansion coefficient) a bond breaks for good, as for ``Critical Stretch``. ``Damage`` of a point
is its broken-bond count over its neighbor count.
"""
from __future__ import annotations

import math

import numpy as np
from pydantic import Field, model_validator

from ..core.interfaces import BlockView
from ..core.params import ModelParams
from .critical_stretch import CriticalStretch


class CriticalEnergyParams(ModelParams):
    critical_energy: float | None = Field(
        None, alias="Critical Energy", gt=0, description="critical energy release rate G0 (energy per crack area: J/m^2 in SI)"
    )
    critical_value: float | None = Field(
        None, alias="Critical Value", gt=0, description="PeriLab's name for Critical Energy (J/m^2); give one of the two"
    )
    thermal_expansion_coefficient: float | None = Field(
        None, alias="Thermal Expansion Coefficient", description="subtracts a_T dT from the stretch (1/temperature); independent of the material's"
    )

    @model_validator(mode="after")
    def _one_value(self):
        if (self.critical_energy is None) == (self.critical_value is None):
            raise ValueError("give exactly one of 'Critical Energy' and 'Critical Value' (the critical energy release rate G0)")
        if self.thermal_expansion_coefficient is not None and not math.isfinite(self.thermal_expansion_coefficient):
            raise ValueError("'Thermal Expansion Coefficient' must be finite")
        return self

    @property
    def G0(self) -> float:
        return float(self.critical_energy if self.critical_energy is not None else self.critical_value)


# ------------------------------------------------------------------------------------------------
# conversions G0 -> s0 (pure functions, SI or any consistent units)
# ------------------------------------------------------------------------------------------------
def bond_based_critical_stretch(G0: float, c: float, delta: float, height: float | None = None) -> float:
    """s0 of a bond-based material of micromodulus c (3D: M L^-5 T^-2; 2D: c of the plane
    model, per thickness ``height``) and horizon delta (L): 3D s0 = sqrt(10 G0 / (pi c delta^5)),
    2D s0 = sqrt(4 G0 / (c h delta^4))."""
    if height is None:
        return math.sqrt((10.0 * G0) / (math.pi * c * delta**5))
    return math.sqrt((4.0 * G0) / (c * height * delta**4))


def _quad(f, a: float, b: float, n: int = 400) -> float:
    """Gauss-Legendre quadrature of a vectorized f on [a, b] (n points)."""
    r, w = np.polynomial.legendre.leggauss(n)
    t = 0.5 * (b - a) * r + 0.5 * (b + a)
    return float(0.5 * (b - a) * np.dot(w, f(t)))


def lps_energy_coefficients(omega) -> tuple[float, float]:
    """(A, B) of G0 = s0^2 delta (A mu + B (K - 5 mu/3)) for the 3D LPS with influence function
    omega(r), r = |xi|/delta in [0, 1] (a vectorized callable). Piecewise-smooth omega are
    integrated on a fine Gauss rule (relative error below 1e-6 for the built-in ones)."""
    P4 = _quad(lambda r: omega(r) * r**4, 0.0, 1.0)
    P5 = _quad(lambda r: omega(r) * r**5, 0.0, 1.0)
    A = 3.75 * P5 / P4

    def g(a: np.ndarray) -> np.ndarray:
        return np.array([(1.5 / P4) * _quad(lambda r, ai=ai: omega(r) * (r**4 - ai * r**3), ai, 1.0, 60) for ai in a])

    B = _quad(lambda a: g(a) ** 2, 0.0, 1.0, 60)
    return A, B


def lps_critical_stretch(G0: float, K: float, mu: float, delta: float, A: float, B: float) -> float:
    """s0 = sqrt(G0 / (delta (A mu + B (K - 5 mu / 3)))) (see lps_energy_coefficients)."""
    stiffness = A * mu + B * (K - 5.0 * mu / 3.0)
    if not stiffness > 0.0:
        raise ValueError(f"Critical Energy: the LPS fracture stiffness A mu + B (K - 5 mu/3) = {stiffness!r} is not positive")
    return math.sqrt(G0 / (delta * stiffness))


class CriticalEnergy(CriticalStretch):
    """Critical energy release rate G0 turned into the critical stretch of the block's material
    (see the module docstring); then a ``Critical Stretch`` model with that value."""

    name = "Critical Energy"
    Params = CriticalEnergyParams

    def __init__(self, params: CriticalEnergyParams, *, options=None) -> None:
        super().__init__(params, options=options)
        self.G0 = params.G0
        self._lps: tuple[float, float, float] | None = None  # (K, mu, delta) until the influence function is known

    def critical_stretch_at(self, time: float) -> float:
        return math.nan  # known once the material is bound

    def bind_material(self, material) -> None:
        delta = material.horizon
        if delta is None or not math.isfinite(delta):
            raise ValueError("Critical Energy needs a constant horizon (give Horizon as a number)")
        moduli = material.elastic_moduli()
        form = material.bond_energy
        if form == "pair" and moduli is not None and moduli.micromodulus is not None:
            height = None if moduli.planar == "3d" else moduli.thickness
            if moduli.planar != "3d" and height is None:
                raise ValueError(f"Critical Energy: the planar material {material.name!r} gives no thickness (ElasticModuli.thickness)")
            self.s_c = bond_based_critical_stretch(self.G0, moduli.micromodulus, delta, height)
        elif form == "lps" and moduli is not None:
            if moduli.planar != "3d":
                raise ValueError(f"Critical Energy: the conversion for the LPS energy ({material.name!r}) is three-dimensional; "
                                 "'Plane Strain'/'Plane Stress' are not supported")
            K, mu = float(moduli.bulk), float(moduli.shear)
            self._lps = (K, mu, float(delta))
            # placeholder until initialize knows the influence function (omega = 1, Peridigm's default)
            self.s_c = lps_critical_stretch(self.G0, K, mu, delta, 25.0 / 8.0, _B_ONE)
        else:
            raise ValueError(
                f"Critical Energy supports the materials whose bonds store the bond-based pair energy or the LPS energy "
                f"(Material.bond_energy 'pair' or 'lps', with elastic_moduli()), such as 'Elastic Bond Based' and 'Elastic', "
                f"not {material.name!r}"
            )

    def initialize(self, block: BlockView) -> None:
        super().initialize(block)
        if self._lps is not None and block.influence is not None and block.influence.spec != "One":
            K, mu, delta = self._lps
            infl = block.influence
            A, B = lps_energy_coefficients(lambda r: infl.evaluate(np.asarray(r) * delta, delta))
            self.s_c = lps_critical_stretch(self.G0, K, mu, delta, A, B)


#: B of lps_energy_coefficients for omega = 1: int_0^1 (3/2 - 15a/8 + 3a^5/8)^2 da = 375/616
_B_ONE = 375.0 / 616.0
