"""Deck parameters of the correspondence materials (PERIDIGM_CORRESPONDENCE.md §1)."""
from __future__ import annotations

from typing import Any

from pydantic import Field, model_validator

from ...core.params import UsedWhen
from ..moduli import IsotropicElasticParams

#: keys whose mere presence Peridigm rejects for every correspondence material
FORBIDDEN = {
    "Apply Automatic Differentiation Jacobian": "correspondence materials always use Peridigm's finite-difference tangent",
    "Apply Shear Correction Factor": "correspondence materials have no shear correction",
}


class CorrespondenceBaseParams(IsotropicElasticParams):
    """Density, two elastic constants and the finite-difference probe of the implicit tangent."""

    finite_difference_probe_length: float | None = Field(
        None, alias="Finite Difference Probe Length", gt=0, description="implicit solvers: probe (L); default 1e-6 x the smallest element radius"
    )

    @model_validator(mode="before")
    @classmethod
    def _forbidden(cls, data: Any) -> Any:
        if isinstance(data, dict):
            for key, why in FORBIDDEN.items():
                if key in data:
                    raise ValueError(f"{key!r} is not a parameter of this material ({why}; Peridigm refuses it too); remove it")
        return data


class ClassicParams(CorrespondenceBaseParams):
    """The classic family (Elastic, Elastic Plastic, Isotropic Hardening, Viscoplastic Needleman
    Correspondence): the hourglass coefficient is required, as in Peridigm."""

    hourglass_coefficient: float = Field(
        alias="Hourglass Coefficient", ge=0, description="C of the hourglass (zero-energy mode) control force, dimensionless; 0 switches it off"
    )


class ElasticCorrespondenceParams(ClassicParams):
    thermal_expansion_coefficient: float | None = Field(
        None, alias="Thermal Expansion Coefficient", description="linear thermal expansion coefficient (1/temperature); enables thermal strain"
    )


class YieldParams(ClassicParams):
    yield_stress: float = Field(alias="Yield Stress", gt=0, description="initial yield stress sigma_y (Pa in SI)")


class FlawParams(YieldParams):
    """The flaw of Isotropic Hardening and Viscoplastic Needleman: a Gaussian dip of the yield
    stress, sigma_y (1 - m exp(-|x - x_f|^2 / s^2)). If 'Enable Flaw' is given (even false),
    the five flaw values are required, as in Peridigm."""

    enable_flaw: bool | None = Field(None, alias="Enable Flaw", description="apply the flaw")
    flaw_location_x: float | None = Field(None, alias="Flaw Location X", description="flaw centre x (L)")
    flaw_location_y: float | None = Field(None, alias="Flaw Location Y", description="flaw centre y (L)")
    flaw_location_z: float | None = Field(None, alias="Flaw Location Z", description="flaw centre z (L)")
    flaw_size: float | None = Field(None, alias="Flaw Size", description="flaw radius s (L); > 0 when 'Enable Flaw' is true")
    flaw_magnitude: float | None = Field(
        None, alias="Flaw Magnitude", description="relative depth m of the yield stress dip (-); 0 to 1 when 'Enable Flaw' is true"
    )
    used_when = {"flaw_size": UsedWhen(lambda p: bool(p.enable_flaw), "'Enable Flaw' is true", gt=0)}

    @model_validator(mode="after")
    def _flaw_complete(self):
        if self.enable_flaw is not None:
            missing = [a for a, v in (("Flaw Location X", self.flaw_location_x), ("Flaw Location Y", self.flaw_location_y),
                                       ("Flaw Location Z", self.flaw_location_z), ("Flaw Size", self.flaw_size),
                                       ("Flaw Magnitude", self.flaw_magnitude)) if v is None]
            if missing:
                raise ValueError(f"'Enable Flaw' is given, so {', '.join(repr(m) for m in missing)} must be given too (as in Peridigm)")
        if self.enable_flaw and not 0.0 <= self.flaw_magnitude <= 1.0:
            raise ValueError(f"'Flaw Magnitude' = {self.flaw_magnitude!r} must be between 0 and 1 when 'Enable Flaw' is true: it is the "
                             "relative depth of the yield stress dip (1 takes the yield stress to 0 at the flaw centre, more makes it "
                             "negative and the plastic update has no solution)")
        return self

    @property
    def flaw(self) -> tuple[float, float, float, float, float] | None:
        """(x, y, z, size, magnitude) when the flaw is applied."""
        if not self.enable_flaw:
            return None
        return (float(self.flaw_location_x), float(self.flaw_location_y), float(self.flaw_location_z), float(self.flaw_size), float(self.flaw_magnitude))


class ElasticPlasticCorrespondenceParams(YieldParams):
    pass


class IsotropicHardeningCorrespondenceParams(FlawParams):
    hardening_modulus: float = Field(alias="Hardening Modulus", description="linear hardening modulus H (Pa in SI)")


class ViscoplasticNeedlemanCorrespondenceParams(FlawParams):
    strain_hardening_exponent: float = Field(alias="Strain Hardening Exponent", ge=0, description="n of (1 + eqps/epsilon_0)^n (-)")
    rate_hardening_exponent: float = Field(
        alias="Rate Hardening Exponent", ge=0, description="m of (plastic rate / reference rate)^m (-); 0 is rate independent"
    )
    reference_strain_rate: float = Field(alias="Reference Strain Rate", gt=0, description="reference plastic strain rate (1/T)")
    reference_strain_0: float = Field(alias="Reference Strain 0", gt=0, description="epsilon_0 of the hardening law")
    reference_strain_1: float = Field(alias="Reference Strain 1", gt=0, description="epsilon_1 of the softening term")
