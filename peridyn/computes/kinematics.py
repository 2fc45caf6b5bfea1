"""Computes from the kinematic state: acceleration, force, energies and momenta
(PERIDIGM_SEMANTICS.md §8.3, with Peridigm's definitions)."""
from __future__ import annotations

import numpy as np

from ..core.fields import FieldSpec, Relation
from ..core.interfaces import Compute


def _owned(sim, name):
    return sim.fields[name][: sim.num_owned]


class Acceleration(Compute):
    """Force_Density (1/rho) (M... L/T^2): the internal force only, not the integrator's
    acceleration (Peridigm's definition)."""

    name = "Acceleration"

    def outputs(self, sim):
        return [FieldSpec("Acceleration", Relation.NODE, 3)]

    def compute(self, sim):
        a = sim.fields["Acceleration"]
        f = sim.fields["Force_Density"]
        for blk in sim.blocks:
            a[blk.start : blk.stop] = f[blk.start : blk.stop] * (1.0 / blk.density)


class Force(Compute):
    """V_i f_i: force on each point (M L/T^2)."""

    name = "Force"

    def outputs(self, sim):
        return [FieldSpec("Force", Relation.NODE, 3)]

    def compute(self, sim):
        sim.fields["Force"][:] = sim.fields["Volume"][:, None] * sim.fields["Force_Density"]


class ContactForce(Compute):
    """V_i times Contact_Force_Density: the contact force on each point (M L/T^2); zero in a run
    without contact."""

    name = "Contact_Force"

    def outputs(self, sim):
        return [FieldSpec("Contact_Force", Relation.NODE, 3)]

    def compute(self, sim):
        fc = sim.fields.get("Contact_Force_Density")
        out = sim.fields["Contact_Force"]
        if fc is None:
            out[:] = 0.0
        else:
            out[:] = sim.fields["Volume"][:, None] * fc


def _kinetic(sim, start, stop, rho):
    v = sim.fields["Velocity"][start:stop]
    vol = sim.fields["Volume"][start:stop]
    return ((0.5 * vol) * rho) * ((v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1]) + v[:, 2] * v[:, 2])


class KineticEnergy(Compute):
    """(V rho / 2) |v|^2 per point (energy)."""

    name = "Kinetic_Energy"

    def outputs(self, sim):
        return [FieldSpec("Kinetic_Energy", Relation.ELEMENT)]

    def compute(self, sim):
        out = sim.fields["Kinetic_Energy"]
        for blk in sim.blocks:
            out[blk.start : blk.stop] = _kinetic(sim, blk.start, blk.stop, blk.density)


class GlobalKineticEnergy(Compute):
    name = "Global_Kinetic_Energy"

    def outputs(self, sim):
        return [FieldSpec("Global_Kinetic_Energy", Relation.GLOBAL)]

    def compute(self, sim):
        total = 0.0
        for blk in sim.blocks:
            total += float(np.sum(_kinetic(sim, blk.start, blk.stop, blk.density)))
        sim.fields["Global_Kinetic_Energy"][0] = sim.comm.allreduce_sum(total)


def _linear(sim, start, stop, rho):
    v = sim.fields["Velocity"][start:stop]
    return (rho * sim.fields["Volume"][start:stop])[:, None] * v


def _angular(sim, start, stop, rho):
    v = sim.fields["Velocity"][start:stop]
    y = sim.fields["Coordinates"][start:stop]
    m = sim.fields["Volume"][start:stop] * rho
    cross = np.stack(
        [v[:, 1] * y[:, 2] - v[:, 2] * y[:, 1], v[:, 2] * y[:, 0] - v[:, 0] * y[:, 2], v[:, 0] * y[:, 1] - v[:, 1] * y[:, 0]], axis=1
    )
    return m[:, None] * cross


class LinearMomentum(Compute):
    """rho V_i v_i per point."""

    name = "Linear_Momentum"

    def outputs(self, sim):
        return [FieldSpec("Linear_Momentum", Relation.NODE, 3)]

    def compute(self, sim):
        out = sim.fields["Linear_Momentum"]
        for blk in sim.blocks:
            out[blk.start : blk.stop] = _linear(sim, blk.start, blk.stop, blk.density)


class AngularMomentum(Compute):
    """rho V_i (v_i x y_i) per point: Peridigm's sign convention (v x y, not y x v)."""

    name = "Angular_Momentum"

    def outputs(self, sim):
        return [FieldSpec("Angular_Momentum", Relation.NODE, 3)]

    def compute(self, sim):
        out = sim.fields["Angular_Momentum"]
        for blk in sim.blocks:
            out[blk.start : blk.stop] = _angular(sim, blk.start, blk.stop, blk.density)


class _GlobalMagnitude(Compute):
    """Sum over blocks of the magnitude of the block's summed vector (Peridigm's definition)."""

    per_point = staticmethod(_linear)

    def outputs(self, sim):
        return [FieldSpec(self.name, Relation.GLOBAL)]

    def compute(self, sim):
        total = 0.0
        for blk in sim.blocks:
            vec = np.sum(self.per_point(sim, blk.start, blk.stop, blk.density), axis=0) if blk.stop > blk.start else np.zeros(3)
            vec = sim.comm.allreduce_sum(vec)
            total += float(np.linalg.norm(vec))
        sim.fields[self.name][0] = total


class GlobalLinearMomentum(_GlobalMagnitude):
    name = "Global_Linear_Momentum"


class GlobalAngularMomentum(_GlobalMagnitude):
    name = "Global_Angular_Momentum"
    per_point = staticmethod(_angular)


class StoredElasticEnergyDensity(Compute):
    """Stored elastic energy per unit volume, from the material (energy/L^3)."""

    name = "Stored_Elastic_Energy_Density"

    def outputs(self, sim):
        return [FieldSpec("Stored_Elastic_Energy_Density", Relation.ELEMENT)]

    def compute(self, sim):
        out = sim.fields["Stored_Elastic_Energy_Density"]
        for blk in sim.blocks:
            blk.material.stored_energy_density(blk.view, out)


class StoredElasticEnergy(Compute):
    """Stored elastic energy of each point: density times volume (energy)."""

    name = "Stored_Elastic_Energy"

    def outputs(self, sim):
        return [FieldSpec("Stored_Elastic_Energy", Relation.ELEMENT)]

    def compute(self, sim):
        out = sim.fields["Stored_Elastic_Energy"]
        for blk in sim.blocks:
            blk.material.stored_energy_density(blk.view, out)
        out *= sim.fields["Volume"]
