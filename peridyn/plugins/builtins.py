"""The built-in models, registered like any plugin. Only names and import paths live here: a
model's module is imported when a deck uses it, so a scene imports only what it needs."""
from __future__ import annotations

from .hookspecs import hookimpl

_K = "peridyn.computes.kinematics"
_G = "peridyn.computes.geometry"
_R = "peridyn.computes.reductions"

#: (output variable or Compute Class name, "module:Class")
BUILTIN_COMPUTES: tuple[tuple[str, str], ...] = (
    ("Acceleration", f"{_K}:Acceleration"),
    ("Force", f"{_K}:Force"),
    ("Contact_Force", f"{_K}:ContactForce"),
    ("Hourglass_Force_Density", "peridyn.materials.correspondence.outputs:HourglassForceDensity"),
    ("Kinetic_Energy", f"{_K}:KineticEnergy"),
    ("Global_Kinetic_Energy", f"{_K}:GlobalKineticEnergy"),
    ("Linear_Momentum", f"{_K}:LinearMomentum"),
    ("Global_Linear_Momentum", f"{_K}:GlobalLinearMomentum"),
    ("Angular_Momentum", f"{_K}:AngularMomentum"),
    ("Global_Angular_Momentum", f"{_K}:GlobalAngularMomentum"),
    ("Stored_Elastic_Energy_Density", f"{_K}:StoredElasticEnergyDensity"),
    ("Stored_Elastic_Energy", f"{_K}:StoredElasticEnergy"),
    ("Element_Id", f"{_G}:ElementId"),
    ("Block_Id", f"{_G}:BlockId"),
    ("Proc_Num", f"{_G}:ProcNum"),
    ("Number_Of_Neighbors", f"{_G}:NumberOfNeighbors"),
    ("Radius", f"{_G}:Radius"),
    ("Neighborhood_Volume", f"{_G}:NeighborhoodVolume"),
    ("Deformation_Gradient", "peridyn.computes.deformation_gradient:DeformationGradient"),
    ("Shape_Tensor_Inverse", "peridyn.computes.deformation_gradient:ShapeTensorInverse"),
    ("Nonlinear_Solver_Iterations", f"{_G}:NonlinearSolverIterations"),
    ("Block_Data", f"{_R}:BlockData"),
    ("Node_Set_Data", f"{_R}:NodeSetData"),
    ("Nearest_Point_Data", f"{_R}:NearestPointData"),
    ("J_Integral", "peridyn.computes.j_integral:JIntegralDomain"),
    ("Fragment_Id", "peridyn.computes.fragments:FragmentId"),
    ("Fragment_Mass", "peridyn.computes.fragments:FragmentMass"),
    ("Fragment_Velocity", "peridyn.computes.fragments:FragmentVelocity"),
    ("Fragment_Kinetic_Energy", "peridyn.computes.fragments:FragmentKineticEnergy"),
    ("Number_Of_Fragments", "peridyn.computes.fragments:NumberOfFragments"),
    ("JIntegral", "peridyn.computes.j_integral:PeridigmJIntegral"),
)



@hookimpl
def peridyn_discretizations():
    return [
        ("PdQuickGrid", "peridyn.io.quickgrid:PdQuickGrid"),
        ("Exodus", "peridyn.io.exodus_mesh:ExodusMesh"),
        ("Text File", "peridyn.io.textfile:TextFile"),
        ("Shapes", "peridyn.io.shapes:Shapes"),
        ("Mesh", "peridyn.io.meshio_mesh:Mesh"),
    ]


@hookimpl
def peridyn_materials():
    return [
        ("Elastic", "peridyn.materials.elastic:Elastic"),
        ("Multiphysics Elastic", "peridyn.materials.multiphysics_elastic:MultiphysicsElastic"),
        ("Elastic Bond Based", "peridyn.materials.elastic_bond_based:ElasticBondBased"),
        ("Regularized Nonlinear Bond", "peridyn.materials.rnp:RNPBond"),
        ("Nonlocal Double Well State", "peridyn.materials.double_well:DoubleWellState"),
        ("Linear LPS Partial Volume", "peridyn.materials.linear_lps_pv:LinearLPSPartialVolume"),
        ("Elastic Partial Volume", "peridyn.materials.linear_lps_pv:ElasticPartialVolume"),
        ("Elastic Plastic", "peridyn.materials.elastic_plastic:ElasticPlastic"),
        ("Elastic Plastic Hardening", "peridyn.materials.elastic_plastic_hardening:ElasticPlasticHardening"),
        ("Viscoelastic", "peridyn.materials.viscoelastic:Viscoelastic"),
        ("Pals", "peridyn.materials.pals:Pals"),
        ("Elastic Correspondence", "peridyn.materials.correspondence.classic:ElasticCorrespondence"),
        ("Stress Law Correspondence", "peridyn.materials.correspondence.user_law:StressLawCorrespondence"),
        ("Elastic Plastic Correspondence", "peridyn.materials.correspondence.classic:ElasticPlasticCorrespondence"),
        ("Isotropic Hardening Correspondence", "peridyn.materials.correspondence.classic:IsotropicHardeningCorrespondence"),
        ("Viscoplastic Needleman Correspondence", "peridyn.materials.correspondence.classic:ViscoplasticNeedlemanCorrespondence"),
        ("Elastic Hypoelastic Correspondence", "peridyn.materials.correspondence.hypoelastic:ElasticHypoelasticCorrespondence"),
        ("Elastic Plastic Hypoelastic Correspondence", "peridyn.materials.correspondence.hypoelastic:ElasticPlasticHypoelasticCorrespondence"),
        ("Isotropic Hardening Hypoelastic Correspondence", "peridyn.materials.correspondence.hypoelastic:IsotropicHardeningHypoelasticCorrespondence"),
        ("Elastic Bond Associated Correspondence", "peridyn.materials.correspondence.bond_associated:ElasticBondAssociatedCorrespondence"),
        ("Elastic Plastic Bond Associated Correspondence", "peridyn.materials.correspondence.bond_associated:ElasticPlasticBondAssociatedCorrespondence"),
        ("Isotropic Hardening Bond Associated Correspondence", "peridyn.materials.correspondence.bond_associated:IsotropicHardeningBondAssociatedCorrespondence"),
        ("Diffusion", "peridyn.materials.diffusion:Diffusion"),
    ]


@hookimpl
def peridyn_damage_models():
    return [
        ("Critical Stretch", "peridyn.damage.critical_stretch:CriticalStretch"),
        ("Time Dependent Critical Stretch", "peridyn.damage.critical_stretch:TimeDependentCriticalStretch"),
        ("Initial Damage", "peridyn.damage.initial_damage:InitialDamage"),
        ("Interface Aware", "peridyn.damage.interface_aware:InterfaceAware"),
        ("Johnson Cook", "peridyn.damage.johnson_cook:JohnsonCook"),
        ("Von Mises Stress", "peridyn.damage.von_mises_stress:VonMisesStress"),
        ("Critical Energy", "peridyn.damage.critical_energy:CriticalEnergy"),
        ("Fatigue", "peridyn.damage.fatigue:Fatigue"),
    ]


@hookimpl
def peridyn_contact_models():
    return [
        ("Short Range Force", "peridyn.contact.short_range:ShortRangeForce"),
        ("Time Dependent Short Range Force", "peridyn.contact.short_range:TimeDependentShortRangeForce"),
        ("Penalty Contact", "peridyn.contact.penalty:PenaltyContact"),
    ]


@hookimpl
def peridyn_solvers():
    return [
        ("Verlet", "peridyn.solvers.explicit.verlet:Verlet"),
        ("QuasiStatic", "peridyn.solvers.implicit.quasistatic:QuasiStatic"),
        ("NOXQuasiStatic", "peridyn.solvers.implicit.nox:NOXQuasiStatic"),
        ("Implicit", "peridyn.solvers.implicit.newmark:Implicit"),
        ("ImplicitDiffusion", "peridyn.solvers.implicit.diffusion:ImplicitDiffusion"),
    ]


@hookimpl
def peridyn_boundary_conditions():
    module = "peridyn.engine.conditions"
    return [
        ("INITIAL_VELOCITY", f"{module}:InitialVelocity"),
        ("INITIAL_DISPLACEMENT", f"{module}:InitialDisplacement"),
        ("INITIAL_TEMPERATURE", f"{module}:InitialTemperature"),
        ("PRESCRIBED_DISPLACEMENT", f"{module}:PrescribedDisplacement"),
        ("PRESCRIBED_TEMPERATURE", f"{module}:PrescribedTemperature"),
        ("BODY_FORCE", f"{module}:BodyForce"),
        ("PRESCRIBED_FLUID_PRESSURE_U", f"{module}:PrescribedFluidPressureU"),
        ("INITIAL_FLUID_PRESSURE_U", f"{module}:InitialFluidPressureU"),
        ("SURFACE_TRACTION", "peridyn.engine.traction:SurfaceTraction"),
    ]


@hookimpl
def peridyn_computes():
    return list(BUILTIN_COMPUTES)


@hookimpl
def peridyn_backends():
    return [
        ("numba", "peridyn.kernels.numba_cpu:NumbaBackend"),
        ("numba-serial", "peridyn.kernels.numba_cpu:SerialNumbaBackend"),
        ("cuda", "peridyn.kernels.numba_cuda:CudaBackend"),
    ]
