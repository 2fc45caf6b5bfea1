"""``brazilian-disk``: Hondros' stresses in their limits, the stretch criterion's prediction, the
exact load on the arcs, the quick point's bands, and a wrong critical stretch fails them."""
import json
import math
import tempfile
from pathlib import Path

import numpy as np
import pytest

from peridyn.verify.problems import brazilian
from peridyn.verify.problems.brazilian import (
    BrazilianDisk, centre_damage_stress, disk_deck, first_damage_stress, hondros, jaw_stresses, jaw_weight,
)
from peridyn.verify.runner import Run


def test_hondros_in_its_limits():
    """A narrow arc is a point load: 2 P / (pi D t) across and -3 times it along the diameter at
    the centre (Timoshenko & Goodier); the load's direction is compressive all along the
    diameter, and the tension across it turns to compression under the arcs."""
    sx, sy = hondros(np.zeros(1), arc=0.01)
    assert sx[0] == pytest.approx(1.0, abs=1e-6) and sy[0] == pytest.approx(-3.0, abs=1e-6)
    r = np.linspace(0.0, 0.999, 500)
    sx, sy = hondros(r, arc=10.0)
    assert np.all(sy < 0.0) and sx[0] > 0.9 and sx[-1] < 0.0
    # the jaws' profile, superposed from uniform arcs: a narrow one is a point load too, and a wide
    # one lies between the uniform arcs of its half-angle and of none
    px, py = jaw_stresses(np.zeros(1), arc=0.02)
    assert px[0] == pytest.approx(1.0, abs=1e-5) and py[0] == pytest.approx(-3.0, abs=1e-5)
    ux = hondros(np.zeros(1), arc=15.0)[0][0]
    assert ux < jaw_stresses(np.zeros(1), arc=15.0)[0][0] < 1.0
    assert jaw_weight(np.array([0.0, 7.5, 15.0, 20.0]), 15.0) == pytest.approx([1.0, 0.5, 0.0, 0.0], abs=1e-12)


def test_the_stretch_criterion_breaks_the_diameter_off_its_centre():
    stress, where = first_damage_stress()
    assert 0.38 < stress < centre_damage_stress() < 0.55 and 0.5 < where < 0.8
    assert first_damage_stress(nu=0.0)[1] == pytest.approx(0.0, abs=1e-3)  # without Poisson's ratio the centre breaks first


def test_the_arcs_carry_the_load_exactly():
    from peridyn.testing import build_simulation

    with tempfile.TemporaryDirectory() as tmp:
        tree, g = disk_deck(1e-3, Path(tmp))
        sim = build_simulation(tree, directory=tmp)
        bcs = tree["Boundary Conditions"]
        gid = sim.gid[: sim.num_owned]
        vol = sim.fields["Volume"]
        for name, cond in (("Top Arc Node Set", "Press down"), ("Bottom Arc Node Set", "Press up")):
            ids = np.array([int(i) - 1 for i in bcs[name].split()])
            from peridyn.deck.expressions import compile_expression

            on = np.isin(gid, ids)
            x = sim.fields["Model_Coordinates"][on]
            b = compile_expression(bcs[cond]["Value"], ("x", "y", "z", "t"))(x=x[:, 0], y=x[:, 1], z=x[:, 2], t=1.0)
            assert abs(float(np.dot(b, vol[on]))) == pytest.approx(g["rate"], rel=1e-12)  # the force at t = 1 s
            assert len(ids) >= 10


def _run(tmp_path, problem):
    rc = Run([problem], tmp_path, quick=True).run()
    return rc, json.loads((tmp_path / "results.json").read_text())["problems"][0]


def test_quick_point_passes_its_bands(tmp_path):
    rc, entry = _run(tmp_path, BrazilianDisk())
    assert rc == 0 and all(c["passed"] for c in entry["checks"]), entry["checks"]
    v = entry["points"][0]["values"]
    assert 0.95 < v["first damage / predicted"] < 1.1 and v["on the diameter"] > 0.9


def test_a_critical_stretch_half_as_large_again_fails(tmp_path, monkeypatch):
    """The material's s0 1.5 times what the prediction assumes: the diameter breaks at about 1.5
    times the predicted load, and the splitting stress is out of its band."""
    run = brazilian.run_disk
    monkeypatch.setattr(brazilian, "run_disk", lambda dx, **kw: run(dx, s0=1.5 * brazilian.BD_S0, **kw))
    rc, entry = _run(tmp_path, BrazilianDisk())
    assert rc != 0
    failed = {c["what"].split(" at ")[0] for c in entry["checks"] if not c["passed"]}
    assert {"first damage on the diameter / predicted load", "splitting stress 2P/(pi D t) / E s0"} <= failed, entry["checks"]
    assert math.isfinite(entry["points"][0]["values"]["first damage / predicted"])
