"""The built-in materials and damage models pass the suites plugin authors use."""
from peridyn.testing import DamageConformance, MaterialConformance


class TestElastic(MaterialConformance):
    material = "Elastic"
    params = {"Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9}  # 3K != 5mu: the dilatation term counts


class TestElasticThermal(MaterialConformance):
    material = "Elastic"
    params = {"Density": 7800.0, "Young's Modulus": 200.0e9, "Poisson's Ratio": 0.3, "Thermal Expansion Coefficient": 1.0e-5}


class TestElasticNearlyIncompressible(MaterialConformance):
    material = "Elastic"
    params = {"Density": 1000.0, "Young's Modulus": 2.0e9, "Poisson's Ratio": 0.45}  # K = 11 G: the moduli checks see G apart


class TestElasticAuxetic(MaterialConformance):
    material = "Elastic"
    params = {"Density": 1000.0, "Bulk Modulus": 1.0e9, "Poisson's Ratio": -0.5}  # the lattice's largest cubic anisotropy


class TestElasticBondBased(MaterialConformance):
    material = "Elastic Bond Based"
    params = {"Density": 7800.0, "Bulk Modulus": 130.0e9}


class TestElasticBondBasedPlaneStress(MaterialConformance):
    material = "Elastic Bond Based"
    params = {"Density": 7800.0, "Young's Modulus": 200.0e9, "Plane Stress": True, "Height": 1.0}


class TestElasticBondBasedPlaneStrain(MaterialConformance):
    material = "Elastic Bond Based"
    params = {"Density": 7800.0, "Bulk Modulus": 130.0e9, "Plane Strain": True, "Height": 0.01}


class TestPals(MaterialConformance):
    material = "Pals"
    params = {"Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9}


class TestPalsGaussian(MaterialConformance):
    material = "Pals"
    params = {"Density": 2700.0, "Young's Modulus": 70.0e9, "Poisson's Ratio": 0.33,
              "Dilatation Influence Function": "Gaussian", "Deviatoric Influence Function": "Parabolic Decay"}


class TestElasticPlastic(MaterialConformance):
    material = "Elastic Plastic"
    params = {"Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9, "Yield Stress": 1.0e12}  # elastic at the kit's strains


class TestElasticPlasticHardening(MaterialConformance):
    material = "Elastic Plastic Hardening"
    params = {"Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9, "Yield Stress": 1.0e12, "Hardening Modulus": 1.0e30}


class TestElasticPlasticYielding(MaterialConformance):
    material = "Elastic Plastic"  # elastic under the moduli checks' strains (1e-5), yielding under the random ones (1e-3)
    params = {"Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9, "Yield Stress": 1.0e7}


class TestElasticPlasticHardeningYielding(MaterialConformance):
    material = "Elastic Plastic Hardening"
    params = {"Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9, "Yield Stress": 1.0e7, "Hardening Modulus": 1.0e45}


class TestViscoelastic(MaterialConformance):
    material = "Viscoelastic"
    params = {"Density": 7800.0, "Bulk Modulus": 160.0e9, "Shear Modulus": 80.0e9, "lambda_i": 0.5, "tau b": 1.0e-3}


class TestCriticalStretch(DamageConformance):
    damage = "Critical Stretch"
    params = {"Critical Stretch": 0.01}


class TestLinearLPSPartialVolume(MaterialConformance):
    material = "Linear LPS Partial Volume"
    params = {"Density": 8.05, "Bulk Modulus": 160.0e9, "Shear Modulus": 79.3e9}
    central = False  # forces along the reference bond

    def test_rigid_motion_gives_zero_force(self):
        """Linearised: a translation gives no force, a rotation by 1e-6 rad forces of its
        second order only (a finite rotation strains a small-strain model)."""
        import numpy as np

        from peridyn.testing.physics_checks import rotation_matrix

        sim = self.scattered_simulation(seed=3)
        scale = self.scale(sim)
        x = sim.fields["Model_Coordinates"]
        sim.fields["Coordinates"][:] = x + self.spacing * np.array([0.3, -1.0, 2.0])
        np.testing.assert_allclose(self.force(sim), 0.0, atol=1e-9 * scale)
        sim.fields["Coordinates"][:] = x @ rotation_matrix(1e-6, [1.0, 2.0, 0.5]).T
        np.testing.assert_allclose(self.force(sim), 0.0, atol=1e-6 * scale)
