"""The verification problems ``peridyn verify`` runs, by name, in the order they run."""
from __future__ import annotations

from .bar import ForceConvergence, WaveSpeed
from .branching import GlassBranching
from .brazilian import BrazilianDisk
from .contact import ContactStability, Hertz
from .contact_penalty import HertzPenalty
from .confined import ConfinedCompression
from .contact_step import ContactStep
from .critical_stretch import CriticalStretch
from .contrast import DensityContrast
from .base import Check, Measurement, Problem
from .dispersion import Dispersion
from .dynamics import Stability, VerletEnergy
from .extreme import ExtremeCases
from .elasticity import DeltaConvergence, Kirsch, PoissonRatio
from .experiments import KalthoffWinkler
from .families import Diffusion, PlasticityUniaxial, ViscoelasticRelaxation
from .griffith import Griffith
from .j_integral import JIntegral
from .lame import LameCylinder
from .lattice import LatticeConstants
from .manufactured import ManufacturedLPS
from .newmark import NewmarkEnergy
from .parallel import ParallelAgreement
from .plate import OneLayerPlate
from .rotation import RigidRotation
from .sphere import LameSphere
from .static import StaticModulus

#: name -> class, in the order ``peridyn verify`` runs them
PROBLEMS: dict[str, type[Problem]] = {
    cls.name: cls
    for cls in (
        WaveSpeed, Dispersion, LatticeConstants, ForceConvergence, VerletEnergy, NewmarkEnergy, Stability, ContactStability, ContactStep, ParallelAgreement, ExtremeCases, RigidRotation, ConfinedCompression, ManufacturedLPS, LameCylinder, LameSphere, DensityContrast, OneLayerPlate, StaticModulus,
        PoissonRatio, Kirsch, DeltaConvergence, CriticalStretch, Griffith, JIntegral, KalthoffWinkler, GlassBranching, BrazilianDisk, Diffusion, ViscoelasticRelaxation, PlasticityUniaxial,
        Hertz, HertzPenalty,
    )
}

__all__ = ["PROBLEMS", "Check", "Measurement", "Problem"]
