"""Contact in whole runs: Peridigm's semantics through the engine, outputs, summary, bad input."""
import math

import netCDF4
import numpy as np
import pytest

from peridyn.cli import main
from peridyn.core.errors import ExitCode
from peridyn.deck.files import dump_yaml

ELASTIC = {"Material Model": "Elastic", "Density": 1000.0, "Bulk Modulus": 1e9, "Shear Modulus": 6e8}


def two_boxes(*, gap=0.2, speed=20.0, k=1e9, mu=0.0, rc=0.8, rs=2.0, freq=5, final=0.06, safety=0.5, extra_contact=None, outputs=None):
    """Two 4x4x4 boxes (spacing 1) facing each other along x, closing at 2 x speed."""
    contact = {
        "Search Radius": rs,
        "Search Frequency": freq,
        "Models": {"Springs": {"Contact Model": "Short Range Force", "Contact Radius": rc, "Spring Constant": k, "Friction Coefficient": mu}},
    }
    contact.update(extra_contact or {})
    return {
        "Discretization": {
            "Type": "Shapes",
            "Omit Bonds Between Blocks": "All",
            "Shapes": {
                "Left": {"Shape": "Box", "Block": "block_1", "Min": [0.0, 0.0, 0.0], "Max": [4.0, 4.0, 4.0], "Spacing": 1.0},
                "Right": {"Shape": "Box", "Block": "block_2", "Min": [4.0 + gap, 0.5, 0.0], "Max": [8.0 + gap, 4.5, 4.0], "Spacing": 1.0},
            },
        },
        "Materials": {"M": ELASTIC},
        "Blocks": {"All": {"Block Names": "block_1 block_2", "Material": "M", "Horizon": 3.015}},
        "Contact": contact,
        "Boundary Conditions": {
            "Push": {"Type": "Initial Velocity", "Node Set": "Left", "Coordinate": "x", "Value": str(speed)},
            "Pull": {"Type": "Initial Velocity", "Node Set": "Right", "Coordinate": "x", "Value": str(-speed)},
        },
        "Solver": {"Final Time": final, "Verlet": {"Safety Factor": safety}},
        "Output": {"Output Filename": "run", "Output Frequency": 20,
                   "Output Variables": outputs or {"Displacement": True, "Velocity": True, "Contact_Force_Density": True, "Contact_Force": True, "Force_Density": True}},
    }


def run(tmp_path, tree, *args):
    deck = tmp_path / "deck.yaml"
    deck.write_text(dump_yaml(tree))
    return main(["run", str(deck), "--output-dir", str(tmp_path), *args])


def read(tmp_path, name):
    with netCDF4.Dataset(tmp_path / "run.e") as ds:
        names = ["".join(c.decode() for c in row if c) for row in ds["name_nod_var"][:].data]
        comps = [ds[f"vals_nod_var{names.index(name + s) + 1}"][:].data for s in "XYZ"]
        return np.stack(comps, axis=-1)


def test_bodies_bounce_with_momentum_conserved_and_contact_in_the_force(tmp_path, capsys):
    assert run(tmp_path, two_boxes()) == ExitCode.OK
    v = read(tmp_path, "Velocity")
    fc = read(tmp_path, "Contact_Force_Density")
    F = read(tmp_path, "Contact_Force")
    f = read(tmp_path, "Force_Density")
    assert np.abs(fc).max() > 0  # they touched
    left, right = v[-1, :64, 0].mean(), v[-1, 64:, 0].mean()
    assert left < 0 < right  # and bounced back
    # equal masses: total x-momentum stays zero
    assert abs(v[-1, :, 0].sum()) <= 1e-9 * np.abs(v[-1, :, 0]).sum()
    # Contact_Force is V x Contact_Force_Density (unit volumes here); Force_Density includes it
    np.testing.assert_allclose(F, fc, rtol=1e-12, atol=0)
    assert np.abs(f - fc).max() > 0  # the bodies deform: an internal part too
    text = capsys.readouterr().err
    assert "contact:" in text and "of the contact radius" in text


def test_the_short_list_gives_exactly_peridigms_pairs(tmp_path, monkeypatch):
    """Pairs listed within R_c + skin and rebuilt on motion act exactly like Peridigm's full
    search-radius lists: a tiny skin (a rebuild every step) gives bit-identical results."""
    tree = two_boxes(freq=7, final=0.04)
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    assert run(a, tree, "-q") == ExitCode.OK
    import peridyn.contact.manager as manager

    monkeypatch.setattr(manager, "SKIN_FRACTION", 1e-9)
    assert run(b, tree, "-q") == ExitCode.OK
    for name in ("Displacement", "Velocity", "Contact_Force_Density"):
        assert np.array_equal(read(a, name), read(b, name)), name


def test_the_search_radius_and_frequency_decide_which_pairs_act(tmp_path):
    # 3.2 apart at the start and closing at 400 m/s: with R_s = 1 the first search lists
    # nothing, so the bodies pass into each other with no contact force until the search at
    # step 40; with R_s = 4 they touch at once (Peridigm: lists are frozen between searches)
    def frames(rs, where):
        where.mkdir()
        assert run(where, two_boxes(gap=2.2, speed=200.0, rs=rs, freq=40, final=0.03), "-q") == ExitCode.OK
        return np.abs(read(where, "Contact_Force_Density")).max(axis=(1, 2))

    narrow, wide = frames(1.0, tmp_path / "narrow"), frames(4.0, tmp_path / "wide")
    assert wide[1] > 0.0  # frame 1 = step 20: the gap closed by 3.7 m
    assert narrow[1] == 0.0 and narrow[2] > 0.0  # frame 2 = step 40: the search found them


@pytest.mark.parametrize(
    "change, expected",
    [
        (lambda t: t["Contact"].update({"Search Frequency": 0}), "Search Frequency"),
        (lambda t: t["Contact"].update({"Search Radius": -1.0}), "Search Radius"),
        (lambda t: t["Contact"].update({"Search Radius": float("nan")}), "Search Radius"),
        (lambda t: t["Contact"].update({"Interactions": {}}), "Interactions"),
        (lambda t: t["Contact"].update({"Interactions": {"note": "x"}}), "Interactions"),
        (lambda t: t["Contact"].pop("Models"), "Models"),
        (lambda t: t["Contact"].update({"Models": {}}), "Models"),
        (lambda t: t["Contact"]["Models"]["Springs"].update({"Horizon": 1.0}), "Horizon"),
        (lambda t: t["Contact"]["Models"]["Springs"].update({"Contact Radius": 0.0}), "Contact Radius"),
        (lambda t: t["Contact"]["Models"]["Springs"].update({"Spring Constant": "inf"}), "Spring Constant"),
        (lambda t: t["Contact"]["Models"]["Springs"].update({"Friction Coefficient": -0.1}), "Friction Coefficient"),
        (lambda t: t["Contact"]["Models"]["Springs"].update({"Contact Model": "Short Range"}), "Contact Model"),
        (lambda t: t["Blocks"]["All"].update({"Horizon": "3.0 + 0*x"}), "Horizon"),
    ],
)
def test_bad_contact_input_is_one_line_exit_2_and_keeps_old_output(tmp_path, capsys, change, expected):
    (tmp_path / "run.e").write_bytes(b"earlier result")
    tree = two_boxes()
    change(tree)
    assert run(tmp_path, tree, "-q") == ExitCode.INPUT_ERROR
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and expected in err[0] and "deck.yaml" in err[0], err
    assert (tmp_path / "run.e").read_bytes() == b"earlier result"


def test_what_peridigm_ignores_is_accepted_with_one_warning(tmp_path, capsys):
    tree = two_boxes(final=2e-3)
    tree["Contact"]["Interactions"] = {"Pair": {"First Block": "block_1", "Second Block": "block_2", "Contact Model": "Springs"}}
    tree["Contact"]["Models"]["Unused"] = {"Contact Model": "Short Range Force", "Contact Radius": 9.0, "Spring Constant": 1.0}
    assert run(tmp_path, tree) == ExitCode.OK
    warnings = capsys.readouterr().err.splitlines()
    assert sum("Interactions is ignored" in w for w in warnings) == 1
    assert sum("only the first model" in w and "Unused" in w for w in warnings) == 1


def test_stiff_contact_warns_at_set_up_and_an_unstable_run_names_contact(tmp_path, capsys):
    tree = two_boxes(k=1e13, safety=0.9, final=0.06, speed=20.0)
    code = run(tmp_path, tree)
    lines = capsys.readouterr().err.splitlines()
    assert any("contact springs" in w and "Safety Factor" in w for w in lines), lines
    assert code == ExitCode.UNSTABLE
    error = [w for w in lines if "unstable" in w]
    assert error and "contact" in error[-1], lines
    with netCDF4.Dataset(tmp_path / "run.e") as ds:  # what was written is finite
        for name, var in ds.variables.items():
            if name.startswith("vals_"):
                assert np.all(np.isfinite(var[:].data)), name


def test_the_suggested_safety_factor_is_stable(tmp_path, capsys):
    tree = two_boxes(k=1e13, safety=0.9, final=2e-3)
    run(tmp_path, tree)
    msg = next(line for line in capsys.readouterr().err.splitlines() if "contact springs" in line)
    factor = float(msg.split("'Safety Factor' <= ")[1].split()[0])
    tree = two_boxes(k=1e13, safety=factor, final=0.06, speed=20.0)
    (tmp_path / "b").mkdir()
    assert run(tmp_path / "b", tree, "-q") == ExitCode.OK
    assert math.isfinite(np.abs(read(tmp_path / "b", "Velocity")).max())
