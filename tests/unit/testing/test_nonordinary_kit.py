"""Every correspondence material passes the non-ordinary conformance suite."""
import pytest

from peridyn.testing import NonOrdinaryConformance

ELASTIC = {"Density": 7800.0, "Bulk Modulus": 160e9, "Shear Modulus": 80e9}
CLASSIC = {**ELASTIC, "Hourglass Coefficient": 0.0}
HYPO = {**ELASTIC, "Actual Horizon": 0.003015}
BA = dict(ELASTIC)
YIELD = {"Yield Stress": 1e12}  # elastic within the checks' small strains


class TestElasticCorrespondence(NonOrdinaryConformance):
    material = "Elastic Correspondence"
    params = CLASSIC


class TestElasticCorrespondenceWithHourglass(NonOrdinaryConformance):
    material = "Elastic Correspondence"
    params = {**ELASTIC, "Hourglass Coefficient": 0.05}


class TestElasticPlasticCorrespondence(NonOrdinaryConformance):
    material = "Elastic Plastic Correspondence"
    params = {**CLASSIC, **YIELD}


class TestIsotropicHardeningCorrespondence(NonOrdinaryConformance):
    material = "Isotropic Hardening Correspondence"
    params = {**CLASSIC, **YIELD, "Hardening Modulus": 1e9}


class TestViscoplasticNeedlemanCorrespondence(NonOrdinaryConformance):
    material = "Viscoplastic Needleman Correspondence"
    params = {**CLASSIC, **YIELD, "Strain Hardening Exponent": 0.1, "Rate Hardening Exponent": 0.01, "Reference Strain Rate": 1.0,
              "Reference Strain 0": 0.01, "Reference Strain 1": 1.0}


class TestElasticHypoelasticCorrespondence(NonOrdinaryConformance):
    material = "Elastic Hypoelastic Correspondence"
    params = HYPO


class TestElasticPlasticHypoelasticCorrespondence(NonOrdinaryConformance):
    material = "Elastic Plastic Hypoelastic Correspondence"
    params = {**HYPO, **YIELD}


class TestIsotropicHardeningHypoelasticCorrespondence(NonOrdinaryConformance):
    material = "Isotropic Hardening Hypoelastic Correspondence"
    params = {**HYPO, **YIELD, "Hardening Characteristic Strain": 0.01, "Hardening Exponent": 0.2}


class TestElasticBondAssociatedCorrespondence(NonOrdinaryConformance):
    material = "Elastic Bond Associated Correspondence"
    params = BA


class TestElasticPlasticBondAssociatedCorrespondence(NonOrdinaryConformance):
    material = "Elastic Plastic Bond Associated Correspondence"
    params = {**BA, **YIELD}


class TestIsotropicHardeningBondAssociatedCorrespondence(NonOrdinaryConformance):
    material = "Isotropic Hardening Bond Associated Correspondence"
    params = {**BA, "Hardening Rule": "Power-law",
              "Hardening Parameters": {"Yield Stress": 1e12, "Hardening Characteristic Strain": 0.01, "Hardening Exponent": 0.2}}


class TestStressLawCorrespondenceNeoHookean(NonOrdinaryConformance):
    """A user's stress law (the shipped Neo-Hookean, mu = G and lambda = K - 2G/3: Hooke's law
    with the deck's constants at small strain)."""

    material = "Stress Law Correspondence"
    params = {**CLASSIC, "Stress Law": "peridyn.materials.correspondence.laws:neo_hookean",
              "Law Parameters": [80e9, 160e9 - 2.0 * 80e9 / 3.0]}


@pytest.mark.parametrize("factor", [1.2, 0.8, -1.0])
def test_the_moduli_check_catches_a_stress_law_of_the_wrong_stiffness(factor):
    """The same law with its constants scaled, the deck's Bulk and Shear Modulus unchanged: it
    passes the rigid-motion, momentum and uniform-stretch checks (any Hookean law does), not the
    stated moduli."""

    class Scaled(TestStressLawCorrespondenceNeoHookean):
        params = {**TestStressLawCorrespondenceNeoHookean.params,
                  "Law Parameters": [factor * v for v in TestStressLawCorrespondenceNeoHookean.params["Law Parameters"]]}

    kit = Scaled()
    if factor > 0:
        kit.test_homogeneous_stretch_gives_uniform_interior_force()
    with pytest.raises(AssertionError):
        kit.test_stated_moduli_under_quadratic_fields()
