"""``Verlet``: explicit velocity-Verlet dynamics, step for step as Peridigm runs it
(PERIDIGM_SEMANTICS.md §6).

Time step: ``Fixed dt`` if given, else the Silling-Askari estimate
min_i sqrt(2 rho / sum_j V_j c / |xi_ij|), c = 18 K / (pi delta^4); either is multiplied by
``Safety Factor`` when given. The number of steps is floor((t_final - t_initial) / dt).
"""
from __future__ import annotations

import logging
import math
import time as _time

import numpy as np
from pydantic import Field

from ...core.errors import InputError, InstabilityError
from ...core.interfaces import Solver
from ...core.params import ModelParams
from ...core.placement import Placement
from ...core.services import RunServices
from ...core.state import SolverState
from ...kernels.scatter import apply_body_forces, apply_kinematic
from ..monitors.energy import EnergyMonitor, judge_energy
from ..section import SolverSection, count_steps
from ..monitors.model_range import RangeWatch
from ..monitors.progress import Progress
from .laws import ACCELERATE, COPY_VECTORS, DRIFT, KICK

log = logging.getLogger("peridyn.solver")


class VerletParams(ModelParams):
    fixed_dt: float | None = Field(None, alias="Fixed dt", gt=0, description="time step (T); default: the critical time step estimate")
    safety_factor: float | None = Field(None, alias="Safety Factor", gt=0, description="multiplies the time step (estimate or Fixed dt)")


class VerletSection(SolverSection):
    verlet: VerletParams = Field(alias="Verlet", description="explicit dynamics")


class Verlet(Solver):
    name = "Verlet"
    Params = VerletSection
    #: the placement of the run in progress (``steps``), None before it starts
    placed: Placement | None = None
    #: (simulation, its critical time step estimate), once computed
    _critical: tuple | None = None

    @classmethod
    def explicit_step(cls, params: VerletSection) -> tuple[float | None, float | None]:
        v = params.verlet
        fixed = v.fixed_dt * v.safety_factor if v.fixed_dt is not None and v.safety_factor is not None else v.fixed_dt
        return fixed, v.safety_factor  # Peridigm multiplies a Fixed dt by the Safety Factor too

    def planned_time_step(self, sim) -> float:
        return self.time_step(sim, warn=False)[0]

    def time_step(self, sim, *, warn: bool = True) -> tuple[float, float]:
        """(dt used, critical estimate)."""
        p = self.params.verlet
        dt_crit = self._estimate(sim)
        dt = p.fixed_dt if p.fixed_dt is not None else dt_crit
        if p.safety_factor is not None:
            dt = dt * p.safety_factor
        if not math.isfinite(dt) or dt <= 0:
            raise InputError(
                f"cannot estimate a stable time step (got {dt!r}): no point has a neighbor, or the horizon is so "
                "large that the bond stiffness vanishes",
                file=sim.deck.file,
                path=(self.section, "Verlet"),
                fix="give 'Fixed dt' or check the horizon against the point spacing",
            )
        if not warn:
            return dt, dt_crit
        if p.safety_factor is not None and p.safety_factor > 1.0:
            log.warning(
                "%s: Safety Factor %.3g > 1: the critical time step estimate is no bound for state-based materials (their "
                "surfaces stiffen them: an LPS plate's limit is about 1.4 times it), and a run this close to the limit can go "
                "unstable where damage stiffens the material",
                self.section, p.safety_factor,
            )
        elif p.fixed_dt is not None and dt > dt_crit:
            log.warning("%s: the time step %.4g exceeds the critical time step estimate %.4g (ratio %.3g)", self.section, dt, dt_crit,
                        dt / dt_crit if dt_crit > 0 else math.inf)
        contact = sim.contact
        if contact is not None:
            dt_c = contact.stable_time_step()
            if dt > dt_c:
                log.warning(
                    "%s: the contact springs (Spring Constant %.4g times the smallest bulk modulus) lower the stable time step "
                    "estimate to %.4g, below the time step %.4g (Peridigm's estimate ignores contact); use %s",
                    self.section, contact.stiffness_ratio(), dt_c, dt,
                    f"'Safety Factor' <= {dt_c / dt_crit:.3g}" if p.fixed_dt is None and math.isfinite(dt_crit) else f"'Fixed dt' <= {dt_c:.4g}",
                )
        return dt, dt_crit

    #: time steps above this fraction of the estimate are checked against the measured limit
    MEASURE_ABOVE = 0.9
    #: growth of an unstable vibration over the run above which it is not run
    MAX_AMPLIFICATION = 1.0e3

    def _measure(self, sim, dt: float, dt_crit: float, steps: int) -> float:
        """The stable limit measured on the model (see :mod:`.stable_step`) when ``dt`` is above
        ``MEASURE_ABOVE`` times the estimate, else inf. InstabilityError when ``dt`` is above it
        and the ``steps`` of the run would amplify the unstable vibration more than
        ``MAX_AMPLIFICATION`` times (a run of a few steps that moves nothing, as Peridigm's
        VariableHorizonParsing at 3.4 times the estimate, still gives its answer)."""
        if not dt > self.MEASURE_ABOVE * dt_crit:
            return math.inf
        from ..monitors.stable_step import measured_stable_step

        limit, iterations = measured_stable_step(sim, dt, stop_below=dt)
        if dt < limit:
            return limit

        def amplification(limit: float) -> float:
            """log10 of the growth over the run of the vibration the bound proves unstable."""
            b = 2.0 * (dt / limit) ** 2 - 1.0  # (w dt)^2/2 - 1 >= 1 for the vibration found
            return steps * math.log10(b + math.sqrt(max(b * b - 1.0, 0.0)))  # |eigenvalue| of a Verlet step

        if amplification(limit) < math.log10(self.MAX_AMPLIFICATION):  # a short run: the full iterations decide
            limit, iterations = measured_stable_step(sim, dt)
        growth = amplification(limit)
        if growth < math.log10(self.MAX_AMPLIFICATION):
            log.warning("%s: the time step %.4g is above the stable limit measured on the model (at most %.4g), but its %d "
                        "step(s) amplify the unstable vibration at most %.3g times", self.section, dt, limit, steps, 10.0**growth)
            return limit
        p = self.params.verlet
        key = "Safety Factor" if p.safety_factor is not None and p.fixed_dt is None else "Fixed dt"
        fit = f"'Safety Factor' below {limit / dt_crit:.3g}" if key == "Safety Factor" else f"a 'Fixed dt' below {limit:.4g}"
        raise InstabilityError(
            f"{self.section}: the run would go unstable from its first step: the time step {dt:.4g} ({dt / dt_crit:.3g} x the "
            f"estimate {dt_crit:.4g}) is above the stable limit measured on the model, at most {limit:.4g} "
            f"({limit / dt_crit:.3g} x the estimate; {iterations} power iterations on its forces); use {fit}"
        )

    def _estimate(self, sim) -> float:
        """The critical time step estimate of ``sim``'s reference configuration (one bond pass),
        computed once per section: its plan (planned_steps) and its run (steps) share it."""
        if self._critical is None or self._critical[0] is not sim:
            self._critical = (sim, sim.critical_time_step())
        return self._critical[1]

    def planned_steps(self, sim) -> int:
        return self._steps(sim, self.time_step(sim, warn=False)[0])

    def _steps(self, sim, dt: float) -> int:
        """floor((t_final - t_initial) / dt); an input error when that cannot be counted or is 0."""
        p = self.params.verlet
        source = "'Fixed dt'" if p.fixed_dt is not None else "the critical time step estimate"
        if p.safety_factor is not None:
            source += " times the Safety Factor"
        return count_steps(self.params.initial_time, self.params.final_time, dt, source=source, file=sim.deck.file,
                           path=(self.section, "Verlet"), hint=sim.unit_slip_hint)

    def run(self, sim, state: SolverState, run: RunServices) -> SolverState:
        for _ in self.steps(sim, state, run):
            pass
        return state

    def placement(self, sim, state: SolverState) -> Placement:
        """Where this run's step arrays live: the simulation's own (the CPU) or copies on the GPU
        backend (made from the host state now: after set-up, or after a checkpoint was loaded),
        with ``state``'s acceleration."""
        if sim.device != "gpu":
            return sim.host_placement(state)
        from ...gpu.placement import DevicePlacement

        return DevicePlacement(sim, sim.device_backend, state)

    def steps(self, sim, state: SolverState, run: RunServices, *, host_each_step: bool = False):
        """The run from ``state``, with the run's services ``run`` (frames, checkpoints,
        progress), as a generator, on every target: yields the step number after step 0 (the
        initial force evaluation and output at t_initial) and after each time step; the run's
        statistics and energy verdict follow the last one; ``state`` is left at the last step.
        :meth:`run` consumes it whole; ``peridyn.api.Model`` advances it step by step
        (the same operations in the same order), with ``host_each_step`` (a GPU run's fields
        copied to the host at every yield)."""
        s = self.params
        instability = InstabilityError  # bound here: a generator left open is closed at exit, after module globals are gone
        dt, dt_crit = self.time_step(sim)
        t0 = s.initial_time
        nsteps = self._steps(sim, dt)
        dt2 = dt / 2.0
        n = sim.num_local
        on = "" if sim.device != "gpu" else " on the GPU"
        log.info("%s: Verlet%s, dt = %.6g (critical estimate %.6g), %d steps from t = %.6g to %.6g", self.section, on, dt, dt_crit,
                 nsteps, t0, t0 + nsteps * dt)
        if state.acceleration is None:
            state.acceleration = np.zeros((n, 3))
        sim.set_time_step(dt)
        restart = run.checkpoints
        # a run continued from a checkpoint: (the last step done, the energy monitor) there
        resumed = restart.resume(self, dt) if restart is not None else None
        setup0 = _time.perf_counter()
        where = self.placed = self.placement(sim, state)
        f = where.fields
        x, y, u, v = f["Model_Coordinates"], f["Coordinates"], f["Displacement"], f["Velocity"]
        has_b = "External_Force_Density" in f
        rho = where.resident(sim.density_per_point())
        backend = where.backend
        kick, drift, accelerate = backend.kernel(KICK), backend.kernel(DRIFT), backend.kernel(ACCELERATE)
        contact = where.contact
        if resumed is None:
            # step 0
            state.time_prev = state.time = t = t0
            where.load_data(t)
            where.evaluate_forces()
            if contact is not None:
                contact.add_force(f["Force_Density"], t, 0)
            apply_kinematic(where, sim.kinematic, t, t)
            apply_body_forces(where, sim.force_conditions, t)
            accelerate(0, n, (f["Force_Density"], f["External_Force_Density"] if has_b else where.no_vectors, rho, dt2,
                              where.acceleration, v, False))
            where.load_data(t)
            where.to_host()
            run.write_output(t)
            limit = self._measure(sim, dt, dt_crit, nsteps)
            if math.isfinite(limit):
                log.info("%s: stable limit measured on the model: at most %.4g (%.3g x the estimate)", self.section, limit, limit / dt_crit)

            monitor = EnergyMonitor(sim, dt, dt_crit, beyond_limit=dt >= limit, where=where)
            first = 1
        else:
            last, monitor = resumed
            monitor.place(where)
            t = t0 + float(last) * dt
            first = last + 1
        f_old = where.zeros((n, 3))
        b_old = where.zeros((n, 3)) if has_b else None
        du = where.zeros((n, 3))
        setup = _time.perf_counter() - setup0
        yield first - 1
        progress = Progress(nsteps, f"{self.section}", enabled=run.progress)
        watch = RangeWatch(sim, nsteps, where)
        files = run.files
        wall0 = _time.perf_counter()
        force_time = 0.0
        try:
            for step in range(first, nsteps + 1):
                t_prev = t
                t = t0 + float(step) * dt
                state.time_prev, state.time = t_prev, t
                sim.begin_step(t)
                if contact is not None:
                    contact.begin_step(step)
                kick(0, n, (v, where.acceleration, dt2))
                apply_kinematic(where, sim.kinematic, t, t_prev)
                copy(where, f_old, f["Force_Density"])
                if has_b:
                    copy(where, b_old, f["External_Force_Density"])
                apply_body_forces(where, sim.force_conditions, t)
                drift(0, n, (v, dt, x, u, y, du))
                where.load_data(t)
                tf0 = _time.perf_counter()
                where.evaluate_forces()
                if contact is not None:
                    contact.add_force(f["Force_Density"], t, step)
                force_time += _time.perf_counter() - tf0
                b_new = f["External_Force_Density"] if has_b else None
                accelerate(0, n, (f["Force_Density"], b_new if has_b else where.no_vectors, rho, dt2, where.acceleration, v, True))
                monitor.force_work(du, f_old, f["Force_Density"], b_old, b_new)
                where.load_data(t)
                monitor.check(step, t)
                watch.after_step(step)
                if host_each_step or files.due_next():
                    where.to_host()
                run.write_output(t)
                where.advance()
                progress.update(step)
                if restart is not None:
                    restart.after_step(step, monitor, where)  # a checkpoint when due or signalled
                yield step
        except instability:
            where.to_host()  # the diagnosis and the last frame read the host's arrays
            raise
        backend.synchronize()
        wall = _time.perf_counter() - wall0
        where.to_host()
        monitor.flush()
        progress.close()
        done = nsteps - first + 1  # the steps this process ran (fewer after a restart)
        log.debug("%s: energy monitor: largest C/S %.4g, largest (K - C)/S %.4g, start energy known %s", self.section,
                  monitor.resolution, monitor.max_excess, monitor.start_known)
        stats = {
            "section": self.section,
            "method": "Verlet",
            "steps": done,
            "dt": dt,
            "dt_estimate": dt_crit,
            "wall": wall,
            "force_time": force_time if sim.device != "gpu" else wall,  # a GPU's launches return before their work is done
            "bond_evaluations": done * sim.num_bonds_global,
            "point_steps": done * sim.num_global,
            "contact": contact.summary() if contact is not None else None,
            "energy": monitor.account(),
        }
        if sim.device == "gpu":
            stats.update(device="gpu", device_setup=setup, device_bytes_per_point=where.memory_per_point())
        sim.stats.setdefault("solvers", []).append(stats)
        p = self.params.verlet
        judge_energy(monitor, self.section, dt, dt_crit, fixed_dt=p.fixed_dt is not None or p.safety_factor is None)


def copy(where: Placement, out, values) -> None:
    """out[:] = values, two (n, 3) arrays on the placement ``where``."""
    where.backend.kernel(COPY_VECTORS)(0, out.shape[0], (values, out))
