"""Built-in computes (output quantities), each computed only when an output writes it."""

_K = "peridyn.computes.kinematics"
_G = "peridyn.computes.geometry"
_R = "peridyn.computes.reductions"

#: (output variable or Compute Class name, "module:Class")
BUILTIN_COMPUTES: tuple[tuple[str, str], ...] = (
    ("Acceleration", f"{_K}:Acceleration"),
    ("Force", f"{_K}:Force"),
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
)
