"""Bad arguments to the Python API are one error naming the call, the argument and what it
accepts (``peridyn.api.checks``: an InputError that is also a ValueError / TypeError /
KeyError); ``model.dt`` before the first step is the step the run takes; ``model.select`` and
region mappings as ``nodes`` select as the deck's regions do."""
from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import peridyn
from peridyn.api.checks import ArgumentError, ArgumentTypeError, UnknownNameError
from peridyn.core.errors import InputError

#: a 12 x 4 x 2 plate of 1 mm points, 8 Verlet steps; two outputs
PLATE = {
    "Discretization": {"Type": "PdQuickGrid", "NeighborhoodType": "Spherical",
                       "TensorProduct3DMeshGenerator": {"Type": "PdQuickGrid", "X Origin": -0.006, "Y Origin": 0.0, "Z Origin": 0.0,
                                                        "X Length": 0.012, "Y Length": 0.004, "Z Length": 0.002,
                                                        "Number Points X": 12, "Number Points Y": 4, "Number Points Z": 2}},
    "Materials": {"Glass": {"Material Model": "Elastic", "Density": 2440.0, "Young's Modulus": 72.0e9, "Poisson's Ratio": 0.22}},
    "Blocks": {"Plate": {"Block Names": "block_1", "Material": "Glass", "Horizon": 0.003015}},
    "Solver": {"Initial Time": 0.0, "Final Time": 1.0e-6, "Verlet": {"Safety Factor": 0.8}},
    "Output": {"Output Filename": "plate", "Output Frequency": 4, "Output Variables": {"Displacement": True}},
    "Output2": {"Output Filename": "plate_history", "Output Frequency": 4, "Output Variables": {"Global_Kinetic_Energy": True}},
}


@pytest.fixture(scope="module")
def model() -> peridyn.Model:
    """A model nobody steps (each bad call below must leave it so)."""
    return peridyn.Model(copy.deepcopy(PLATE), write_files=False)


def fresh() -> peridyn.Model:
    return peridyn.Model(copy.deepcopy(PLATE), write_files=False)


N = 12 * 4 * 2
LEFT = {"Half Space": {"Point": [-0.004, 0, 0], "Normal": [-1, 0, 0]}}


@pytest.mark.parametrize("call, arg, error", [
    (lambda m: m.step(-1), "n", ArgumentError),
    (lambda m: m.step(2.5), "n", ArgumentTypeError),
    (lambda m: m.step(True), "n", ArgumentTypeError),
    (lambda m: m.step("3"), "n", ArgumentTypeError),
    (lambda m: m.run(until=float("nan")), "until", ArgumentError),
    (lambda m: m.run(until="1e-6"), "until", ArgumentTypeError),
    (lambda m: m.run(until=-1.0), "until", ArgumentError),
    (lambda m: m.get("Stress"), "name", UnknownNameError),
    (lambda m: m.get(3), "name", ArgumentTypeError),
    (lambda m: m.set("Velocity", np.zeros((3, 3))), "values of Velocity", ArgumentError),
    (lambda m: m.set("Velocity", np.zeros((N, 2))), "values of Velocity", ArgumentError),
    (lambda m: m.set("Velocity", np.full((N, 3), np.inf)), "values of Velocity", ArgumentError),
    (lambda m: m.set("Velocity", np.full((N, 3), "a")), "values of Velocity", ArgumentTypeError),
    (lambda m: m.set("Velocity", np.zeros((N, 3), complex)), "values of Velocity", ArgumentTypeError),
    (lambda m: m.set("Velocity", [[1.0, 2.0], [3.0]]), "values of Velocity", ArgumentTypeError),
    (lambda m: m.add_condition("Prescribed Velocity Of Nothing", LEFT, lambda t, x: t), "type", ArgumentError),
    (lambda m: m.add_condition("Prescribed Displacement", LEFT, lambda t, x: t, coordinate="w"), "coordinate", ArgumentError),
    (lambda m: m.add_condition("Prescribed Displacement", LEFT, lambda t, x: t, coordinate=0), "coordinate", ArgumentTypeError),
    (lambda m: m.add_condition("Prescribed Displacement", [0, N], lambda t, x: t), "nodes", ArgumentError),
    (lambda m: m.add_condition("Prescribed Displacement", [-1], lambda t, x: t), "nodes", ArgumentError),
    (lambda m: m.add_condition("Prescribed Displacement", [0.5, 1.0], lambda t, x: t), "nodes", ArgumentTypeError),
    (lambda m: m.add_condition("Prescribed Displacement", np.zeros(5, bool), lambda t, x: t), "nodes", ArgumentError),
    (lambda m: m.add_condition("Prescribed Displacement", {"Cube": {}}, lambda t, x: t), "nodes", ArgumentError),
    (lambda m: m.add_condition("Prescribed Displacement", {"Half Space": {"Point": [0, 0], "Normal": [1, 0, 0]}}, lambda t, x: t),
     "nodes", ArgumentError),
    (lambda m: m.add_condition("Body Force", {"Box": {"Min": [1, 1, 1], "Max": [2, 2, 2]}}, lambda t, x: t), "nodes", ArgumentError),
    (lambda m: m.add_condition("Body Force", "Nowhere", lambda t, x: t), "name", UnknownNameError),
    (lambda m: m.add_condition("Body Force", LEFT, "1.0"), "value", ArgumentTypeError),
    (lambda m: m.add_condition("Body Force", LEFT, float("nan")), "value", ArgumentError),
    (lambda m: m.add_compute("c", lambda m: 0.0, every=0), "every", ArgumentError),
    (lambda m: m.add_compute("c", lambda m: 0.0, every=2.5), "every", ArgumentTypeError),
    (lambda m: m.add_compute("c", 3.0), "fn", ArgumentTypeError),
    (lambda m: m.add_compute("", lambda m: 0.0), "name", ArgumentTypeError),
    (lambda m: m.history("nothing"), "name", UnknownNameError),
    (lambda m: m.node_set("Nowhere"), "name", UnknownNameError),
    (lambda m: m.select([0, 1]), "region", ArgumentTypeError),
    (lambda m: m.select({"Sphere": {"Center": [0, 0, 0], "Radius": -1}}), "region", ArgumentError),
    (lambda m: m.results(2), "which", ArgumentError),
    (lambda m: m.results(-3), "which", ArgumentError),
    (lambda m: m.results(1.0), "which", ArgumentTypeError),
    (lambda m: m.results("Output7"), "which", UnknownNameError),
])
def test_a_bad_argument_is_one_error_naming_it(model, call, arg, error) -> None:
    with pytest.raises(error) as info:
        call(model)
    exc = info.value
    assert isinstance(exc, InputError) and exc.path[-1] == arg and exc.fix
    assert "\n" not in exc.one_line() and exc.path[0] in str(exc)
    assert model.steps_taken == 0 and not model.sim.conditions  # nothing half done


def test_the_kinds_of_error_are_the_builtin_ones_too(model) -> None:
    with pytest.raises(ValueError):
        model.step(-1)
    with pytest.raises(TypeError):
        model.step(1.5)
    with pytest.raises(KeyError):
        model.get("Stress")


def test_step_zero_does_nothing_and_numpy_ints_count(model) -> None:
    m = fresh()
    assert m.step(0) is m and m.steps_taken == 0
    m.step(np.int64(2))
    assert m.steps_taken == 2 and m.time == pytest.approx(2 * m.dt, rel=1e-12)


def test_dt_before_the_first_step_is_the_step_the_run_takes() -> None:
    m = fresh()
    before = m.dt
    assert before > 0 and np.isfinite(before)
    m.step(1)
    assert m.dt == before  # bit for bit: the solver's own computation
    assert before == pytest.approx(0.8 * m.sim.critical_time_step(), rel=1e-15)


def test_dt_with_a_fixed_step_and_of_a_section_that_chooses_its_own() -> None:
    tree = copy.deepcopy(PLATE)
    tree["Solver"]["Verlet"] = {"Fixed dt": 1.0e-8}
    assert peridyn.Model(tree, write_files=False).dt == 1.0e-8
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": 1.0, "QuasiStatic": {"Number of Load Steps": 2, "Absolute Tolerance": 1.0}}
    with pytest.raises(ArgumentError, match="known after the first step"):
        peridyn.Model(tree, write_files=False).dt  # noqa: B018


def test_run_until_now_or_later_is_accepted() -> None:
    m = fresh()
    m.run(until=0.0)  # the current time: step 0 only
    t = m.time
    m.run(until=t)
    assert m.time == t
    with pytest.raises(ArgumentError, match="before the current time"):
        m.run(until=t - 1e-7)


def test_set_accepts_whole_number_arrays_of_any_real_dtype(model) -> None:
    m = fresh()
    m.set("Velocity", np.ones((N, 3), dtype=np.int32))
    assert np.all(m["Velocity"] == 1.0)
    m["Velocity"] = [2.0, 0, 0]  # one row broadcast to every point
    assert np.all(m["Velocity"][:, 0] == 2.0)


def test_select_is_a_region_with_the_regions_tolerance(model) -> None:
    x = model.x[:, 0]
    left = model.select({"Half Space": {"Point": [-0.004, 0, 0], "Normal": [-1, 0, 0]}})
    right = model.select({"Half Space": {"Point": [np.float32(0.004), np.int64(0), 0], "Normal": np.array([1, 0, 0])}})
    assert left.shape == (N,) and left.dtype == bool
    assert left.sum() == right.sum() == 2 * 4 * 2  # two columns each, mirrored about x = 0
    assert np.allclose(np.sort(np.unique(x[left])), -np.sort(np.unique(x[right]))[::-1])
    assert model.select({"All": True}).all()


def test_a_region_as_nodes_equals_its_mask() -> None:
    a, b = fresh(), fresh()
    a.add_condition("Initial Velocity", LEFT, lambda t, x: np.full(len(x), 3.0))
    b.add_condition("Initial Velocity", b.select(LEFT), lambda t, x: np.full(len(x), 3.0))
    assert np.array_equal(a["Velocity"], b["Velocity"]) and (a["Velocity"][:, 0] == 3.0).sum() == 16


def test_from_points_node_sets_take_regions_and_bad_arrays_are_named() -> None:
    h = 1.0e-3
    g = -0.003 + (np.arange(6) + 0.5) * h  # round-off in the coordinates, as a generator makes them
    x = np.stack(np.meshgrid(g, g[:2], g[:2], indexing="ij"), axis=-1).reshape(-1, 3)
    deck = {k: copy.deepcopy(PLATE[k]) for k in ("Materials", "Solver", "Output")}
    deck["Blocks"] = {"Plate": {"Block Names": "block_1", "Material": "Glass", "Horizon": 0.003015}}
    m = peridyn.Model.from_points(x, h**3, deck, write_files=False,
                                  node_sets={"Left": {"Half Space": {"Point": [-0.0025, 0, 0], "Normal": [-1, 0, 0]}},
                                             "Right": {"Half Space": {"Point": [0.0025, 0, 0], "Normal": [1, 0, 0]}}})
    assert len(m.node_set("Left")) == len(m.node_set("Right")) == 4
    for kwargs, arg in [({"x": x[:, :1]}, "x"), ({"x": np.full_like(x, np.nan)}, "x"), ({"volume": np.ones(3)}, "volume"),
                        ({"volume": -1.0}, "volume"), ({"volume": np.inf}, "volume"), ({"block_id": np.ones(5, int)}, "block_id"),
                        ({"block_id": 0}, "block_id"), ({"block_id": 1.5}, "block_id"),
                        ({"node_sets": {"A": [len(x)]}}, "node_sets['A']"), ({"node_sets": {"A": {"Box": {}}}}, "node_sets['A']"),
                        ({"node_sets": [1, 2]}, "node_sets"), ({"deck": "deck.yaml"}, "deck"),
                        ({"deck": {**deck, "Discretization": {"Type": "PdQuickGrid"}}}, "deck")]:  # not silently replaced
        args = {"x": x, "volume": h**3, "deck": deck, **kwargs}
        with pytest.raises(ArgumentError) as info:
            peridyn.Model.from_points(args.pop("x"), args.pop("volume"), args.pop("deck"), write_files=False, **args)
        assert info.value.path == ("Model.from_points", arg), kwargs


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n=st.one_of(st.integers(-5, 3), st.floats(allow_nan=True), st.booleans(), st.text(max_size=2), st.none()))
def test_step_takes_whole_numbers_and_refuses_the_rest(n) -> None:
    m = _STEPPER
    before = m.steps_taken
    if isinstance(n, int) and not isinstance(n, bool) and n >= 0:
        m.step(n)
        assert m.steps_taken == before + n
    else:
        with pytest.raises(ArgumentError) as info:
            m.step(n)
        assert info.value.path == ("Model.step", "n") and m.steps_taken == before


@settings(max_examples=60, deadline=None)
@given(values=st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), min_size=1, max_size=4),
    st.integers(-10, 10), st.text(max_size=3), st.booleans()))
def test_set_takes_finite_broadcastable_numbers_only(values) -> None:
    m = _STEPPER
    arr = np.asarray(values)
    ok = arr.dtype.kind in "iuf" and np.all(np.isfinite(arr)) and arr.shape in ((), (1,), (3,))
    if ok:
        m.set("Velocity", values)
        assert np.array_equal(m["Velocity"], np.broadcast_to(arr.astype(float), (N, 3)))
    else:
        with pytest.raises(ArgumentError) as info:
            m.set("Velocity", values)
        assert info.value.path == ("Model.set", "values of Velocity")


def _long_run() -> peridyn.Model:
    tree = copy.deepcopy(PLATE)
    tree["Solver"]["Final Time"] = 1.0e-3  # thousands of steps: the hypothesis tests step it on
    return peridyn.Model(tree, write_files=False)


_STEPPER = _long_run()  # shared by the hypothesis tests


@pytest.mark.parametrize("kwargs, arg, error", [
    ({"parameters": []}, "parameters", ArgumentError),
    ({"parameters": {"Solver/Final Time": 1e-6}}, "parameters", ArgumentTypeError),
    ({"parameters": "Solver/Final Time"}, "parameters", ArgumentTypeError),
    ({"parameters": [3.0]}, "parameters", ArgumentTypeError),
    ({"parameters": [{"": 1.0}]}, "parameters", ArgumentError),
    ({"parameters": [{"Solver/Final Time": None}]}, "parameters", ArgumentError),
    ({"parameters": [{"Solver/Final Time": {1, 2}}]}, "parameters", ArgumentError),
    ({"extract": "max_damage"}, "extract", ArgumentTypeError),
    ({"folder": 3}, "folder", ArgumentTypeError),
    ({"deck": 3}, "deck", ArgumentTypeError),
])
def test_bad_study_arguments_are_named(tmp_path, kwargs, arg, error) -> None:
    args = {"deck": copy.deepcopy(PLATE), "parameters": [{"Solver/Final Time": 1e-6}], "folder": tmp_path / "s", **kwargs}
    with pytest.raises(error) as info:
        peridyn.Study(args.pop("deck"), args.pop("parameters"), args.pop("folder"), **args)
    assert info.value.path == ("Study", arg)
    assert not (tmp_path / "s").exists()


def test_bad_study_grid_and_processes_are_named(tmp_path) -> None:
    for axes in ({"Solver/Final Time": 1e-6}, {"Solver/Final Time": "1e-6"}, {"Solver/Final Time": []}):
        with pytest.raises(ArgumentError) as info:
            peridyn.Study.grid(**axes)
        assert info.value.path == ("Study.grid", "Solver/Final Time")
    study = peridyn.Study(copy.deepcopy(PLATE), [{"Solver/Final Time": np.float64(1e-6)}], tmp_path / "s")
    assert study.parameters == [{"Solver/Final Time": 1e-6}]
    for processes in (0, 1.5, "2"):
        with pytest.raises(ArgumentError) as info:
            study.run(processes=processes)
        assert info.value.path == ("Study.run", "processes")
    assert not (tmp_path / "s").exists()


# found by benchmarks/surface_campaign.py ---------------------------------------------------------
def test_callables_of_the_wrong_arity_are_named_when_added() -> None:
    m = fresh()
    with pytest.raises(ArgumentTypeError, match=r"Model.add_compute > fn: .*takes \(\)"):
        m.add_compute("c", lambda: 1.0)
    with pytest.raises(ArgumentTypeError, match=r"Model.add_condition > value"):
        m.add_condition("Body Force", LEFT, lambda t: 1.0)
    with pytest.raises(ArgumentTypeError, match=r"Model.add_condition > nodes"):
        m.add_condition("Body Force", lambda: None, 1.0)
    m.close()


@pytest.mark.parametrize("value, error", [(lambda t, x: "s", ArgumentTypeError), (lambda t, x: np.zeros(7), ArgumentError),
                                          (lambda t, x: np.zeros((len(x), 2)), ArgumentError)])
def test_a_value_callable_returning_no_numbers_is_named(value, error) -> None:
    m = fresh()
    m.add_condition("Body Force", LEFT, value)
    with pytest.raises(error, match=r"Model.add_condition > value: value\(t, x\) returned"):
        m.step(2)
    m.close()


def test_nodes_as_a_two_dimensional_index_array_is_refused() -> None:
    m = fresh()
    with pytest.raises(ArgumentError, match=r"Model.add_condition > nodes: .*indices have shape \(1, 2\)"):
        m.add_condition("Body Force", np.array([[0, 1]]), 1.0)
    m.close()


@pytest.mark.parametrize("path", [3, None, 2.5])
def test_read_of_something_that_is_no_path_names_path(path) -> None:
    with pytest.raises(ArgumentTypeError, match=r"peridyn.read > path: path must be a file name"):
        peridyn.read(path)


@pytest.mark.parametrize("arg", ["output_dir", "directory"])
def test_a_folder_argument_that_is_no_path_is_named(arg) -> None:
    with pytest.raises(ArgumentTypeError, match=rf"Model > {arg}: {arg} must be a folder name"):
        peridyn.Model(copy.deepcopy(PLATE), write_files=False, **{arg: float("nan")})


@pytest.mark.parametrize("arg", ["backend", "device"])
def test_backend_and_device_that_are_no_text_are_named(arg) -> None:
    """Found by benchmarks/surface_campaign.py: Model(device=[]) was an AttributeError."""
    with pytest.raises(ArgumentTypeError, match=rf"Model > {arg}: {arg} must be a name"):
        peridyn.Model(copy.deepcopy(PLATE), write_files=False, **{arg: []})
