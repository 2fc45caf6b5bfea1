"""The log lines of a run: the model after set-up, and at the end each solver section's steps,
rate and energy balance, contact statistics, and per-rank balance under MPI."""
from __future__ import annotations

import logging
from pathlib import Path

from ..core.services import OutputFiles

log = logging.getLogger("peridyn")


def log_setup(sim) -> None:
    """Points, blocks, bonds and the set-up time."""
    log.info(
        "%s: %d points in %d block(s), %d bonds; set-up %.2f s (mesh %.2f s, neighbors %.2f s)",
        Path(sim.deck.file).name,
        sim.num_global,
        len(sim.blocks),
        sim.num_bonds_global,
        sim.timers.get("setup", 0.0),
        sim.timers.get("read mesh", 0.0),
        sim.timers.get("neighbor search", 0.0),
    )


def log_summary(sim, files: OutputFiles, wall: float) -> None:
    """Each solver section's steps, rate, energy balance and contact statistics, the ranks'
    balance (collective under MPI), and the output ``files`` written; ``wall``: the run's seconds."""
    for st in sim.stats.get("solvers", []):
        steps = st.get("steps", 0)
        rate = st["bond_evaluations"] / st["wall"] if st.get("wall") else 0.0
        msg = f"{st['section']} ({st['method']}): {steps} steps in {st['wall']:.2f} s"
        if steps and st.get("wall"):
            msg += f", {rate / 1e6:.1f} M bond evaluations/s, {st['point_steps'] / st['wall'] / 1e6:.2f} M point-steps/s"
        log.info(msg)
        e = st.get("energy")
        if e:
            scale = max(abs(e["kinetic_initial"]), abs(e["kinetic"]), abs(e["stored_from_work"]), abs(e["external_work"]) + abs(e["constraint_work"]), 1e-300)
            log.info(
                "  energy: kinetic %.6g -> %.6g, stored %+.6g, work by loads %+.6g, by prescribed motion %+.6g; balance error %.3g (%.2g%% of the energy scale, worst %.2g%%)",
                e["kinetic_initial"],
                e["kinetic"],
                e["stored_from_work"],
                e["external_work"],
                e["constraint_work"],
                e["balance_error"],
                100 * abs(e["balance_error"]) / scale,
                100 * e["max_relative_error"],
            )
            if e.get("created", 0.0) > 0.0:
                log.warning("  energy: NOT balanced: the stored energy is negative, %.6g created by the materials (see the "
                            "warning above)", e["created"])
        if st.get("device") == "gpu":
            log.info("  device: gpu, fields and bonds %.0f bytes per point on the device, copied there in %.2f s",
                     st["device_bytes_per_point"], st["device_setup"])
        c = st.get("contact")
        if c:
            _log_contact(c, steps)
    if sim.comm.size > 1:
        _log_parallel(sim)
    written = [f"{w.path.name}.{sim.comm.size}.0 ... .{sim.comm.size - 1} (per rank)" if w.piece is not None and
               not w.entry.params.merge_rank_files else str(w.path.name) for w in files.writers if w.frames]
    log.info("done in %.2f s; wrote %s", wall, ", ".join(written) if written else "no output")


def _log_contact(c: dict, steps: int) -> None:
    builds = max(1, int(c["builds"]))
    pen = c["penetration"]
    log.info(
        "  contact: %d searches, %d pair-list builds (%.3g ms each), contact force %.3g ms per step, %d pairs listed at the end (largest %d)%s",
        c["searches"], c["builds"], 1e3 * c["build_time"] / builds, 1e3 * (c["force_time"] - c["build_time"]) / max(1, c["force_calls"]),
        c["pairs"], c["max_pairs"], f", {c['ghosts']} contact ghosts at most" if c.get("ghosts") else "",
    )
    if c.get("sync_time"):
        log.info("  contact: %.3g ms per step waiting for the other ranks in its collective check (the force evaluation's imbalance)",
                 1e3 * c["sync_time"] / max(1, c["force_calls"]))
    if pen < 1.0:
        log.info("  contact: smallest pair distance %.4g = %.3g of the contact radius %.4g (penetration %.1f%%)",
                 c["min_distance"], pen, c["contact_radius"], 100.0 * max(0.0, 1.0 - pen))
    else:
        log.info("  contact: no pair came within the contact radius %.4g", c["contact_radius"])


def _log_parallel(sim) -> None:
    """Per-rank balance, ghosts, communication and memory (collective: every rank calls it)."""
    import resource

    steps = max(1, sum(st.get("steps", 0) for st in sim.stats.get("solvers", [])))
    halo = sim.halo
    mine = (
        sim.num_owned,
        sim.num_local - sim.num_owned,
        int(sim.bonds.num_bonds),
        halo.bytes_sent / steps,
        halo.seconds / steps,
        resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    )
    rows = sim.comm.allgather(mine)
    for rank, (owned, ghosts, bonds, nbytes, secs, rss) in enumerate(rows):
        log.info(
            "  rank %d: %d points, %d ghosts (%.1f%%), %d bonds, halo %.1f kB and %.3f ms per step, peak memory %.0f MiB",
            rank, owned, ghosts, 100.0 * ghosts / max(owned, 1), bonds, nbytes / 1e3, secs * 1e3, rss,
        )
    if sim.overlap:
        log.info("  halo messages overlapped with the computation of the points without ghost neighbors")
