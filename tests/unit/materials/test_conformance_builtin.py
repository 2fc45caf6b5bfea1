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


class TestCriticalStretch(DamageConformance):
    damage = "Critical Stretch"
    params = {"Critical Stretch": 0.01}
