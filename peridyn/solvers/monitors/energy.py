"""The energy / stability monitor of an explicit section: the energy account of every step, the
stop of an unstable run with its diagnosis, and the verdict on the section's energy balance."""
from __future__ import annotations

import logging
import math

import numpy as np

from ...core.errors import InstabilityError
from ..explicit.laws import KINETIC_FREE, STEP_SUMS

log = logging.getLogger("peridyn.solver")


#: largest energy balance error of a trusted run, relative to its energy (see EnergyMonitor)
SUSPECT_BALANCE_ERROR = 0.03
def judge_energy(monitor: "EnergyMonitor", section: str, dt: float, dt_crit: float, fixed_dt: bool) -> None:
    """After an explicit run: a warning when the energy balance was off by more than
    SUSPECT_BALANCE_ERROR, naming the step that would bring it to about 1 % (the error falls as
    dt^2). The run is not stopped: a stable run's answer is Verlet's answer to the deck, as
    Peridigm's (see ``EnergyMonitor.check``). Nothing when the account is not kept (thermal
    strain) or the energy is negligible."""
    created = monitor.created()
    if created > 0.0:
        log.warning(
            "%s: the body ends with a negative stored energy (%.4g, %.2g%% of the run's largest energy): its materials "
            "gave it energy no load supplied, so the closed energy balance does not vouch for this run; a model outside "
            "its range (see any warning above on strain or rotation) does this", section, -created, 100.0 * created / monitor.max_scale,
        )
    if not (monitor.accounting and monitor.max_scale > monitor.floor and monitor.max_error > SUSPECT_BALANCE_ERROR):
        return
    better = dt * math.sqrt(0.01 / monitor.max_error)
    fit = f"a 'Fixed dt' of {better:.3g}" if fixed_dt else f"a 'Safety Factor' of {better / dt_crit:.3g}"
    log.warning(
        "%s: the energy of the run was off by up to %.1f%% (velocity Verlet's energy error, bounded in a stable run: "
        "the vibrations that carry the energy are resolved by few steps per period; accurate runs stay below 1%%): "
        "%s gives about 1%%", section, 100.0 * monitor.max_error, fit,
    )


class EnergyMonitor:
    """Tracks the energy balance of an explicit run and stops it when it goes unstable.

    The balance is kept over the free degrees of freedom; prescribed ones belong to whatever
    drives them. Kinetic energy K (free components) is exact; the stored energy E is integrated
    from the work of the internal forces on all points, dE = -sum V f . du (trapezoidal rule
    over each step); body forces do W_b = sum_free V b . du; the prescribed motion does
    W_c = -sum_prescribed V f . du on the body. For a stable run K + E - W_b - W_c stays at its
    initial value up to the integrator's O(dt^2) error. (With thermal expansion the temperature
    change also does work that is not tracked, so there the balance is reported but not used
    as a stopping criterion.)

    ``check`` runs every step and costs O(points). Under MPI the per-step sums of ``batch``
    steps are reduced over ranks together, in one reduction (the same sums step by step, so the
    same decisions, made at most ``batch - 1`` steps later): a reduction every step would make
    every rank wait for the slowest one once more per step. A run is stopped as unstable when

    * velocities or forces become non-finite; or
    * the kinetic energy at least doubles at every one of ``window`` consecutive steps (1000x
      growth in 10 steps: an explicit-integration instability, not physics, which grows
      polynomially from rest); or
    * with a valid energy account, the balance error exceeds both the energy present before the
      growth began and half the energy present now, while the kinetic energy grew at each of
      the last ``window // 2`` steps (a physical run keeps the error a small fraction); or
    * with a valid energy account and materials that report their stored energy, energy was
      created: breaking bonds only dissipates energy, so the true stored energy
      E0 + E - D (E0 at the start, D >= 0 dissipated) is never negative, and a run whose
      E0 + E falls below ``-created_fraction`` of the largest energy present while the kinetic
      energy grows has made kinetic energy from nothing. This is what sees a blow-up that
      shatters a body: its bonds break and the balance closes, but the energy came from the
      integrator.
    """

    #: energy created, as a fraction of the largest energy present, that stops a run
    created_fraction = 0.25
    #: C0 / E0 of the initial state above which its vibrations are resolved by too few steps
    #: (w dt > 1.41)
    coarse = 0.5
    #: C / S that stops a run (see _check_account)
    unstable_ratio = 4.0
    #: energy error |C - C0| / S that stops a run whose step is above the measured limit
    beyond_limit_error = 0.03
    #: kinetic energy beyond the supply (and C) that stops a run, as a fraction of the supply
    excess = 0.5
    #: per-step growth of the kinetic energy, at 3 consecutive steps, that stops a run without
    #: an energy account
    fast_growth = 1000.0

    def __init__(self, sim, dt: float, dt_estimate: float, *, window: int = 10, accounting: bool = True, batch: int | None = None,
                 beyond_limit: bool = False, where) -> None:
        self.sim = sim
        self.batch = batch if batch is not None else (1 if sim.comm.size == 1 else 16)
        self._rows: list[tuple[int, float, np.ndarray]] = []  # (step, time, local sums) not yet reduced
        self.dt = dt
        self.dt_estimate = dt_estimate
        self.window = window
        self.accounting = accounting and "Temperature_Change" not in sim.fields
        n = sim.num_owned
        self.mass = sim.fields["Volume"][:n] * sim.density_per_point()[:n]
        self.free = np.ascontiguousarray(~sim.prescribed_dofs[:n])
        self._empty = np.zeros((0, 3))
        self.place(where)
        self.has_prescribed = not bool(self.free.all())
        self.kinetic0 = self.kinetic_free()
        self.shadow0 = self.shadow = sim.comm.allreduce_sum(self._shadow_local())
        self.kinetic = self.kinetic0
        self.stored = 0.0  # relative to the start of this solver
        self.external = 0.0
        self.constraint = 0.0
        self.load_shadow = 0.0  # C_b of the last step (see supply)
        self._pending = None  # (du, f_old, f_new, b_old, b_new) of the step's force_work
        self.history: list[tuple[float, float]] = []  # (kinetic, energy scale) of recent steps
        self.max_balance = 0.0  # largest |balance| seen
        self.max_scale = abs(self.kinetic0)  # largest energy present at any time
        #: stored energy at the start, when every material reports one (else None: no test of
        #: created energy, since a body may start stretched)
        self.stored0 = sim.stored_energy() if self.accounting and self._energy_known(sim) else None
        if self.stored0 is not None and not math.isfinite(self.stored0):  # a contact model without an energy
            self.stored0 = None
        if self.stored0 is not None:
            self.max_scale = max(self.max_scale, abs(self.stored0))
        #: the stored energy at the start where it is known: what the materials report, or 0 for
        #: a body in its reference configuration (no displacement), whatever its materials
        u = sim.fields["Displacement"][:n]
        at_reference = sim.comm.allreduce_max(float(np.abs(u).max()) if n else 0.0) == 0.0
        self.start_energy = self.stored0 if self.stored0 is not None else (0.0 if at_reference else None)
        #: energy of a strain of 1e-6 everywhere: below it, ratios of energies are round-off
        volume = sim.comm.allreduce_sum(float(np.sum(sim.fields["Volume"][:n])))
        stiffest = max((float(blk.material.bulk_modulus) for blk in sim.blocks), default=0.0)
        self.floor = 1e-12 * volume * stiffest if math.isfinite(volume * stiffest) else 0.0
        #: the ratio rules need the energy at the start; where no material reports it and the
        #: body starts loaded (step-0 forces), it is bounded below only by what the run releases,
        #: and only a gross excess is taken as proof
        self.start_known = self.stored0 is not None or not self.shadow0 > self.floor
        self.released = 0.0  # largest energy the body has given up so far (-E, E from work)
        self.resolution = 0.0  # largest C / S seen (see _check_account)
        self.max_excess = 0.0  # largest (K - C) / S seen
        self.fast: list[float] = [self.kinetic0]  # kinetic energies of the last steps (no accounting)
        #: the step is above the stable limit measured on the model (a run too short for the
        #: unstable vibration to grow much was let start): any energy error it shows stops the run
        self.beyond_limit = beyond_limit
        if self.stored0 is not None and self.stored0 > self.floor:
            self._check_start()

    def place(self, where) -> None:
        """Reduce each step's sums where the step's arrays are (``where``, a
        :class:`~peridyn.core.placement.Placement`, whose solver state's host acceleration the
        diagnosis reads); seven numbers then cross to the host."""
        self._step = (where, where.resident(self.free), where.resident(self.mass), where.zeros(STEP_SUMS.width))

    def supply(self) -> float:
        """S = K0 + E0 + |W_b| + |W_c| + 2 C_b (+ what the body released, where E0 is unknown): the
        most energy the run can hold, since breaking bonds, friction and plasticity only dissipate.

        C_b = dt^2/8 sum m |b/rho|^2 (free components) is the part of C the loads b alone give:
        a load that has just grown (a ramp, a step in time, a load switched on at any step) has
        done no work yet, because the drift that carries its work comes a step after its
        acceleration, while C already holds its share. The next step's drift then does about
        2 C_b of work on a body at rest (a load present from t = 0 does exactly that in the
        first step). C_b is bounded by the loads, so a blow-up still passes it."""
        e0 = self.stored0 if self.stored0 is not None else max(self.shadow0, self.released)
        return (self.kinetic0 + max(e0, 0.0) + abs(self.external) + abs(self.constraint) + 2.0 * self.load_shadow
                + self.floor)

    @staticmethod
    def _energy_known(sim) -> bool:
        from ...core.interfaces import Material

        return all(type(blk.material).stored_energy_density is not Material.stored_energy_density for blk in sim.blocks)

    def _shadow_local(self) -> float:
        a = self._step[0].state.acceleration
        if a is None:
            return 0.0
        return self._shadow_of(a)

    def _shadow_of(self, a: np.ndarray) -> float:
        """C = dt^2/8 sum_i m_i |a_i|^2 over the owned points' free components, for accelerations
        ``a`` (n, 3): dt^2/4 times the kinetic energy a velocity field ``a`` would have."""
        return self._shadow_from(self._kinetic_of(a))

    def _kinetic_of(self, v: np.ndarray) -> float:
        """0.5 sum_i m_i |v_i|^2 over the owned points' free components, in point order (host arrays)."""
        out = np.zeros(1)
        self.sim.backend.kernel(KINETIC_FREE)(0, self.sim.num_owned, (v, self.mass, self.free), out)
        return float(out[0])

    def _shadow_from(self, sum_: float) -> float:
        """dt^2/4 times a ``_kinetic_of`` sum of accelerations: C."""
        return 0.25 * self.dt * self.dt * sum_

    def _kinetic_local(self) -> float:
        return self._kinetic_of(self.sim.fields["Velocity"])

    def kinetic_free(self) -> float:
        return self.sim.comm.allreduce_sum(self._kinetic_local())

    # called by the integrator ------------------------------------------------------------------
    def force_work(self, du: np.ndarray, f_old: np.ndarray, f_new: np.ndarray, b_old, b_new) -> None:
        """Account for one step: displacement increment du (n, 3), internal force densities
        before/after, body force densities before/after (or None). The sums are reduced over
        ranks together with the next ``check`` (one reduction per step)."""
        empty = self._step[0].no_vectors
        self._pending = (du, f_old, f_new, b_old if b_old is not None else empty, b_new if b_new is not None else empty)

    def created(self) -> float:
        """Energy the materials made from nothing by the end of the run: -(E0 + E) where the start
        energy E0 is known and the total stored energy E0 + E is negative beyond the integrator's
        error (twice the largest balance error, and round-off); else 0. A body cannot store a
        negative energy: a model that gives it one is outside the range where it is a material."""
        if self.start_energy is None or not self.accounting:
            return 0.0
        created = -(self.start_energy + self.stored)
        return created if created > 2.0 * self.max_balance + 1e-9 * self.max_scale + self.floor else 0.0

    def account(self) -> dict[str, float]:
        """The run's energy account for the summary (see ``_account``)."""
        return {
            "created": self.created(),
            "kinetic_initial": self.kinetic0,
            "kinetic": self.kinetic,
            "stored_from_work": self.stored,
            "external_work": self.external,
            "constraint_work": self.constraint,
            "balance_error": self.balance,
            "max_relative_error": self.max_error,
            "resolution": self.resolution,
            "kinetic_over_supply": self.max_excess,
        }

    @property
    def max_error(self) -> float:
        """Largest balance error of the run relative to the largest energy present."""
        return self.max_balance / self.max_scale if self.max_scale > 0 else 0.0

    @property
    def balance(self) -> float:
        """K + E - W_b - W_c - K0: zero for an exact integration."""
        return self.kinetic + self.stored - self.external - self.constraint - self.kinetic0

    def _scale(self) -> float:
        return max(abs(self.kinetic), abs(self.stored), abs(self.external), abs(self.constraint), abs(self.kinetic0))

    def check(self, step: int, time: float) -> None:
        """Account for the step just completed (after ``force_work``); raises InstabilityError."""
        sim = self.sim
        where, free, mass, sums = self._step
        f = where.fields
        work, self._pending = self._pending, None
        a = where.acceleration
        if work is None:  # no force_work this step: no work done
            force = f["Force_Density"]
            work = (where.zeros(force.shape), force, force, where.no_vectors, where.no_vectors)
        args = (*work, f["Volume"], free, f["Velocity"], a if a is not None else where.no_vectors, mass)
        where.backend.kernel(STEP_SUMS)(0, sim.num_owned, args, sums)
        w_all, w_presc, w_body, kinetic, force, shadow, load = (float(v) for v in where.backend.to_host(sums))
        local = np.array([w_all, w_presc, w_body, kinetic, force, self._shadow_from(shadow), self._shadow_from(load)])
        if sim.comm.size == 1:
            self._account(step, time, local)
            return
        self._rows.append((step, time, local))
        if len(self._rows) >= self.batch:
            self.flush()

    def flush(self) -> None:
        """Reduce and account for the steps checked but not yet reduced (MPI; the solver calls
        this after its last step)."""
        if not self._rows:
            return
        rows, self._rows = self._rows, []
        totals = self.sim.comm.allreduce_sum(np.stack([r[2] for r in rows]))
        for (step, time, _), total in zip(rows, totals):
            self._account(step, time, total)

    def _account(self, step: int, time: float, total: np.ndarray) -> None:
        """One step's global sums: (internal work, work on prescribed components, body-force
        work, kinetic energy of free components, sum of force densities, C, C_b)."""
        self.stored -= total[0]
        self.constraint -= total[1]
        self.external += total[2]
        self.kinetic = float(total[3])
        self.shadow = float(total[5])
        self.load_shadow = float(total[6])
        if not (math.isfinite(total[3]) and math.isfinite(total[4])):
            self._fail_nonfinite(step, time)
        scale = self._scale()
        err = abs(self.balance)
        self.max_balance = max(self.max_balance, err)
        self.max_scale = max(self.max_scale, scale)
        self.history.append((self.kinetic, scale))
        if self.accounting:
            self._check_account(step, time)
        else:
            self._check_fast_growth(step, time)
        w = self.window
        if len(self.history) <= w:
            return
        self.history.pop(0)
        ke = [h[0] for h in self.history]
        ratios = [b / a if a > 0 else (math.inf if b > 0 else 1.0) for a, b in zip(ke, ke[1:])]
        if all(r >= 2.0 for r in ratios):
            self._fail_growth(step, time, ke[-1] / ke[0] if ke[0] > 0 else math.inf)
        half = w // 2
        if self.stored0 is not None and ke[-1] > ke[0]:
            created = -(self.stored0 + self.stored)
            if created > self.created_fraction * self.max_scale and created > self.floor:  # not round-off
                self._fail_created(step, time, created)
        if self.accounting and all(r > 1.0 for r in ratios[-half:]):
            before = self.history[0][1]
            if before > 0 and err > max(before, 0.5 * scale) and ke[-1] > 4.0 * ke[-half - 1]:
                self._fail_growth(step, time, ke[-1] / ke[-half - 1] if ke[-half - 1] > 0 else math.inf, steps=half)

    def _check_account(self, step: int, time: float) -> None:
        """The rules that need no history, so that a run of a few steps is judged too.

        Velocity Verlet conserves, for linear forces, the shadow energy K + E - C with
        C = dt^2/8 sum m |a|^2 over free components (the trapezoidal balance K + E - W - K0
        above equals C - C0 exactly). For one vibration of frequency w, C / E = (w dt)^2 / 4 =: r:
        below 1 when the step is stable for it. The energy E the run holds is at most the supply S
        plus C (see ``supply``), so a stable run keeps C / S below r / (1 - r): a few at most
        unless w dt is close to 2. A run whose C / S passes ``unstable_ratio`` (r >= 0.8,
        w dt >= 1.79) is at or past the stability limit of the vibrations that carry its energy;
        a blow-up passes it within a few steps, and a step far above the limit at the first.
        Independently, the kinetic energy cannot exceed S by more than C (the same identity with
        E >= 0): ``excess`` bounds the round-off and nonlinear slack of that.

        C - C0 is also Verlet's energy error itself (K + E differs from the conserved shadow
        energy by C): bounded in a stable run, and large where the vibrations that carry the
        energy are resolved by few steps per period, which the estimate does not see (a chain of
        four LPS points at half the estimate's step: 50 %; a small LPS bar struck at one end at
        the estimate's step: 110 %). That is Verlet's answer to the deck, as Peridigm's: it is
        reported at the end of the run (``Verlet``), not stopped.
        """
        self.released = max(self.released, -self.stored)
        supply = self.supply()
        if not supply > 0.0:
            return
        ratio = self.shadow / supply
        self.resolution = max(self.resolution, ratio)
        self.max_excess = max(self.max_excess, (self.kinetic - self.shadow) / supply)
        factor = 1.0 if self.start_known else 100.0
        if ratio > self.unstable_ratio * factor:
            self._fail_accelerations(step, time, ratio)
        if self.kinetic - self.shadow > (1.0 + self.excess) * factor * supply:
            self._fail_excess(step, time, supply)
        if self.beyond_limit and abs(self.shadow - self.shadow0) > max(self.beyond_limit_error * supply, self.floor):
            self._fail_accelerations(step, time, ratio, beyond=True)

    def _check_start(self) -> None:
        """The initial state alone: for linear forces E0 = u.Ku/2 and the same sum as C over the
        internal (and contact) forces, C0 = dt^2/8 u.K M^-1 K u, so C0 / E0 <= (w_max dt)^2/4
        (a Rayleigh quotient); body forces and velocities are left out, as they store nothing."""
        sim = self.sim
        n = sim.num_owned
        rho = sim.density_per_point()[:n]
        local = self._shadow_of(sim.fields["Force_Density"][:n] / rho[:, None])
        ratio = sim.comm.allreduce_sum(local) / (self.kinetic0 + self.stored0 + self.floor)
        self.resolution = max(self.resolution, ratio)
        if ratio > self.coarse:
            self._fail_resolution(0, sim.clock.time, ratio)

    def _check_fast_growth(self, step: int, time: float) -> None:
        """Without an energy account: kinetic energy 1000x larger at each of 3 consecutive steps
        (a physical load would need to grow like t^24)."""
        self.fast.append(self.kinetic)
        if len(self.fast) > 4:
            self.fast.pop(0)
        k = self.fast
        if len(k) == 4 and all(b > self.fast_growth * a if a > 0 else b > 0 for a, b in zip(k, k[1:])) and k[-1] > self.floor:
            self._fail_growth(step, time, k[-1] / k[0] if k[0] > 0 else math.inf, steps=3)

    # diagnosis --------------------------------------------------------------------------------
    def _locate(self, vectors: np.ndarray | None) -> str:
        """The point whose vector (rows of ``vectors``, local points) is not finite, else the
        largest, over all ranks ("" where there is none)."""
        sim = self.sim
        self._step[0].to_host()  # a GPU run's arrays, for the diagnosis
        n = sim.num_owned
        where, size = "", -1.0
        if n and vectors is not None:
            mag = np.einsum("ij,ij->i", vectors[:n], vectors[:n])
            mag = np.where(np.isfinite(mag), mag, np.inf)
            k = int(np.argmax(mag))
            size = float(mag[k])
            x = sim.fields["Model_Coordinates"][k]
            blk = sim.blocks[int(sim.block_index[k])].name
            where = f"point {int(sim.gid[k]) + 1} (block {blk}, x = {x[0]:.4g}, {x[1]:.4g}, {x[2]:.4g})"
        if sim.comm.size > 1:
            size, where = max(sim.comm.allgather((size, where)), key=lambda c: c[0])
        return where

    def _worst_point(self) -> str:
        """The point with a non-finite velocity, else the fastest one, over all ranks."""
        return self._locate(self.sim.fields["Velocity"])

    def _fastest_acceleration(self) -> str:
        """The point of largest acceleration over all ranks (where the step is least resolved)."""
        return self._locate(self._step[0].state.acceleration)

    def _advice(self) -> str:
        self._step[0].to_host()  # the contact's state of a GPU run
        contact = self.sim.contact
        note = contact.diagnosis(self.dt) if contact is not None else ""
        if note.startswith("contact springs"):  # the contact springs are what the step cannot resolve
            return note
        ratio = self.dt / self.dt_estimate if self.dt_estimate > 0 else float("inf")
        slip = self.sim.unit_slip_hint()
        if not ratio < 1e3:  # a broken estimate (a density of 1e-297, say): no thousand-digit number
            advice = f"the time step {self.dt:.4g} is far above the stable estimate {self.dt_estimate:.4g}; check the density and moduli"
        elif slip and ratio <= 1.0:  # the step is within the estimate: the model, not the step, is wrong
            advice = f"the time step {self.dt:.4g} is {ratio:.2f} times the stable estimate {self.dt_estimate:.4g}; {slip}"
            slip = ""
        else:
            advice = (
                f"the time step {self.dt:.4g} is {ratio:.2f} times the stable estimate {self.dt_estimate:.4g}; "
                f"use 'Safety Factor' <= 1 or a 'Fixed dt' below {self.dt_estimate:.4g}"
            )
        if slip:
            advice = f"{advice}; {slip}"
        return f"{advice}; {note}" if note else advice

    def _fail_nonfinite(self, step: int, time: float) -> None:
        where = self._worst_point()
        raise InstabilityError(
            f"the run went unstable at step {step} (t = {time:.6g}): non-finite velocity or force at {where}; " + self._advice()
        )

    def _fail_created(self, step: int, time: float, created: float) -> None:
        where = self._worst_point()
        raise InstabilityError(
            f"the run went unstable at step {step} (t = {time:.6g}): {created:.3g} of kinetic energy appeared that no load "
            f"supplied and no stored energy released ({created / self.max_scale:.0%} of the largest energy of the run; bond "
            f"breaking can only dissipate energy), fastest at {where}; " + self._advice()
        )

    def _fail_resolution(self, step: int, time: float, ratio: float) -> None:
        where = self._fastest_acceleration()
        raise InstabilityError(
            f"the run was stopped at step {step} (t = {time:.6g}): the time step resolves the vibrations that carry the initial "
            f"energy with fewer than 4.4 steps per period (Verlet's stability parameter (w dt)^2/4 measured on the initial state: "
            f"at least {ratio:.3g}; stable below 1, accurate well below 0.5), largest at {where}; " + self._advice()
        )

    def _fail_accelerations(self, step: int, time: float, ratio: float, *, beyond: bool = False) -> None:
        where = self._fastest_acceleration()
        what = (
            f"the time step is above the stable limit measured on the model and its unstable vibration now holds "
            f"{abs(self.shadow - self.shadow0) / self.supply():.1%} of all the energy supplied (an energy error, dt^2/8 sum m|a|^2)"
            if beyond
            else f"the time step is at or past the stability limit of the vibrations that carry the energy (dt^2/8 sum m|a|^2 is "
            f"{ratio:.3g} times all the energy supplied to the run; a stable step keeps it a fraction of it)"
        )
        raise InstabilityError(f"the run went unstable at step {step} (t = {time:.6g}): {what}, largest acceleration at {where}; "
                               + self._advice())

    def _fail_excess(self, step: int, time: float, supply: float) -> None:
        where = self._worst_point()
        raise InstabilityError(
            f"the run went unstable at step {step} (t = {time:.6g}): its kinetic energy {self.kinetic:.4g} exceeds all the "
            f"energy the initial state and the loads supplied ({supply:.4g}), fastest at {where}; " + self._advice()
        )

    def _fail_growth(self, step: int, time: float, growth: float, steps: int | None = None) -> None:
        where = self._worst_point()
        raise InstabilityError(
            f"the run went unstable at step {step} (t = {time:.6g}): kinetic energy grew {growth:.3g}x in the last {steps or self.window} "
            f"steps with no work to account for it (energy balance error {abs(self.balance):.3g}), fastest at {where}; " + self._advice()
        )
