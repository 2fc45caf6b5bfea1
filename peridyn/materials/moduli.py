"""Elastic constants from any two of bulk, shear, Young's modulus and Poisson's ratio, as
Peridigm computes them (PERIDIGM_SEMANTICS.md §1.7, same operation order)."""
from __future__ import annotations

from pydantic import Field, model_validator

from ..core.interfaces import ElasticModuli
from ..core.params import STRESS_RATIO_LIMIT, ModelParams, ParamKeyError


def bulk_and_shear(
    K: float | None = None,
    G: float | None = None,
    E: float | None = None,
    nu: float | None = None,
    *,
    plane_strain: bool = False,
    plane_stress: bool = False,
) -> tuple[float, float]:
    """(bulk modulus, shear modulus) from exactly two of K, G, E, nu.

    Plane strain / plane stress change K only, and only for the (E, nu) pair. Raises ValueError
    unless exactly two are given.
    """
    given = [name for name, v in (("Bulk Modulus", K), ("Shear Modulus", G), ("Young's Modulus", E), ("Poisson's Ratio", nu)) if v is not None]
    if len(given) != 2:
        raise ValueError(
            f"give exactly two of 'Bulk Modulus', 'Shear Modulus', \"Young's Modulus\", \"Poisson's Ratio\" (got {', '.join(given) or 'none'})"
        )
    try:
        return _from_pair(K, G, E, nu, plane_strain, plane_stress)
    except ZeroDivisionError:  # a pair on the edge of the admissible range (E = 9K, E = 3G, nu = 1/2, ...)
        raise ValueError(f"{given[0]} and {given[1]} give no finite bulk and shear modulus (Poisson's ratio at -1 or 1/2): "
                         "give elastic constants of a material with -1 < nu < 1/2") from None


def _from_pair(K, G, E, nu, plane_strain: bool, plane_stress: bool) -> tuple[float, float]:
    if K is not None:
        if G is not None:
            return K, G
        if E is not None:
            return K, (3.0 * K * E) / (9.0 * K - E)
        return K, (3.0 * K * (1.0 - 2.0 * nu)) / (2.0 * (1.0 + nu))
    if E is not None and G is not None:
        return (E * G) / (3.0 * (3.0 * G - E)), G
    if E is not None and nu is not None:
        if plane_strain:
            k = E / (2.0 * (1.0 - nu - (2.0 * nu) * nu))
        elif plane_stress:
            k = E / (2.0 * (1.0 - nu))
        else:
            k = E / (3.0 * (1.0 - 2.0 * nu))
        return k, E / (2.0 * (1.0 + nu))
    # G and nu
    return (2.0 * G * (1.0 + nu)) / (3.0 * (1.0 - 2.0 * nu)), G


class IsotropicElasticParams(ModelParams):
    """Density and two elastic constants: the parameters every isotropic material shares."""

    density: float = Field(alias="Density", gt=0, description="mass density (M/L^3, kg/m^3 in SI)")
    bulk_modulus: float | None = Field(None, alias="Bulk Modulus", gt=0, description="bulk modulus K (M/(L T^2), Pa in SI)")
    shear_modulus: float | None = Field(None, alias="Shear Modulus", gt=0, description="shear modulus G (Pa in SI)")
    youngs_modulus: float | None = Field(None, alias="Young's Modulus", gt=0, description="Young's modulus E (Pa in SI)")
    poissons_ratio: float | None = Field(None, alias="Poisson's Ratio", gt=-1.0, lt=0.5, description="Poisson's ratio nu (dimensionless, -1 < nu < 0.5)")
    plane_strain: bool = Field(False, alias="Plane Strain", description="2D plane strain (changes K for the E, nu pair)")
    plane_stress: bool = Field(False, alias="Plane Stress", description="2D plane stress (changes K for the E, nu pair)")

    @model_validator(mode="after")
    def _two_constants(self):
        if self.plane_strain and self.plane_stress:
            raise ValueError("'Plane Strain' and 'Plane Stress' cannot both be true")
        self.moduli()
        return self

    @model_validator(mode="after")
    def _stress_scale(self):
        """Yield stresses (any '... Yield Stress' key) more than 1e100 times below or above the
        elastic moduli: their squares and ratios to the moduli (yield value, plastic multiplier)
        under- or overflow, and a plastic run stops as unstable or with a NaN residual."""
        given = [v for v in (self.bulk_modulus, self.shear_modulus, self.youngs_modulus) if v]
        if not given:
            return self
        modulus = max(given)
        for name, field in type(self).model_fields.items():
            alias = field.alias or name
            value = getattr(self, name, None)
            if "Yield Stress" not in alias or isinstance(value, bool) or not isinstance(value, float) or value <= 0.0:
                continue
            if not self.is_used(name):
                continue
            ratio = value / modulus
            if not 1.0 / STRESS_RATIO_LIMIT <= ratio <= STRESS_RATIO_LIMIT:
                raise ParamKeyError(alias, f"{alias!r} = {value!r} is {ratio:.3g} times the elastic modulus ({modulus:g}): the yield "
                                           "value and plastic multiplier built from it under- or overflow, and the run would stop as "
                                           "unstable or with NaN; give a yield stress within 1e100 of the modulus (usually 1e-4 to 1e-1 of it)")
        return self

    def moduli(self) -> tuple[float, float]:
        """(K, G)."""
        return bulk_and_shear(
            self.bulk_modulus,
            self.shear_modulus,
            self.youngs_modulus,
            self.poissons_ratio,
            plane_strain=self.plane_strain,
            plane_stress=self.plane_stress,
        )


def isotropic_moduli(params: IsotropicElasticParams, K: float, mu: float, *, hookean: bool) -> ElasticModuli:
    """``Material.elastic_moduli`` of a material with :class:`IsotropicElasticParams`: (K, mu)
    as the material computed them, planar as its Plane Strain / Plane Stress flags say."""
    planar = "plane strain" if params.plane_strain else "plane stress" if params.plane_stress else "3d"
    return ElasticModuli(float(K), float(mu), planar, hookean=hookean)
