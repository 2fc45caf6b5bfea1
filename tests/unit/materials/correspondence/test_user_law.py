"""``Stress Law Correspondence`` with the shipped Neo-Hookean law: a body stretched to 1.5 times
its length (every point prescribed, so F is exact at every point) carries the closed-form Cauchy
stress; rotated rigidly as well, the stress rotates with it; the law's state is carried from step
to step; and a law that cannot be loaded is one clear input error."""
import math

import numpy as np
import pytest

from peridyn.core.errors import InputError
from peridyn.testing import build_simulation, cube_deck
from peridyn.engine.session import run_sections

MU, LAM = 80.0e9, 50.0e9
LAW = {"Material Model": "Stress Law Correspondence", "Density": 7800.0, "Shear Modulus": MU, "Bulk Modulus": LAM + 2.0 * MU / 3.0,
       "Hourglass Coefficient": 0.0, "Stress Law": "peridyn.materials.correspondence.laws:neo_hookean", "Law Parameters": [MU, LAM]}


def neo_hookean(F):
    J = np.linalg.det(F)
    return (MU / J) * (F @ F.T - np.eye(3)) + (LAM / J) * math.log(J) * np.eye(3)


def prescribed(F_end, material=LAW, steps=4):
    """A 4^3 cube whose points all follow x -> F(t) x, F(t) = I + (t/T)(F_end - I), to t = T."""
    tree = cube_deck(material, n=4, spacing=1.0e-3)
    n = 64
    tree["Boundary Conditions"] = {"All Node Set": " ".join(str(k + 1) for k in range(n))}
    G = np.asarray(F_end) - np.eye(3)
    T = steps * 1.0e-8
    for a, c in enumerate("xyz"):
        value = "+".join(f"({float(G[a, b])!r})*{'xyz'[b]}" for b in range(3))
        tree["Boundary Conditions"][f"Move {c}"] = {"Type": "Prescribed Displacement", "Node Set": "All Node Set", "Coordinate": c,
                                                     "Value": f"(t/{T!r})*({value})"}
    tree["Solver"] = {"Initial Time": 0.0, "Final Time": T, "Verlet": {"Fixed dt": 1.0e-8}}
    tree["Output"] = {"Output Filename": "law", "Output Frequency": steps, "Output Variables": {"Cauchy_Stress": True}}
    return tree


def final_stress(tmp_path, F_end):
    sim = build_simulation(prescribed(F_end), directory=tmp_path)
    run_sections(sim)
    # a step ends by swapping the two-step fields: the last step's values are in N
    return sim.fields.n("Cauchy_Stress")[: sim.num_owned].reshape(-1, 3, 3), sim


def test_uniaxial_stretch_of_fifty_percent_gives_the_closed_form_stress(tmp_path):
    """F = diag(1.5, 1, 1): sigma_xx = (mu (1.5^2 - 1) + lambda ln 1.5) / 1.5, sigma_yy =
    sigma_zz = lambda ln 1.5 / 1.5, no shear."""
    F = np.diag([1.5, 1.0, 1.0])
    sigma, _ = final_stress(tmp_path, F)
    expected = np.diag([(MU * 1.25 + LAM * math.log(1.5)) / 1.5, LAM * math.log(1.5) / 1.5, LAM * math.log(1.5) / 1.5])
    for s in sigma:
        np.testing.assert_allclose(s, expected, rtol=1e-9, atol=1e-9 * abs(expected[0, 0]))


def test_a_rotated_stretch_rotates_the_stress(tmp_path):
    q = math.radians(30.0)
    Q = np.array([[math.cos(q), -math.sin(q), 0.0], [math.sin(q), math.cos(q), 0.0], [0.0, 0.0, 1.0]])
    F = Q @ np.diag([1.5, 1.0, 1.0])
    sigma, sim = final_stress(tmp_path, F)
    expected = Q @ neo_hookean(np.diag([1.5, 1.0, 1.0])) @ Q.T
    assert np.allclose(expected, neo_hookean(F))  # objectivity of the law itself
    for s in sigma:
        np.testing.assert_allclose(s, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())
    F_law = sim.fields.n("Stress_Law_Deformation_Gradient")[: sim.num_owned].reshape(-1, 3, 3)
    np.testing.assert_allclose(F_law, np.broadcast_to(F, F_law.shape), rtol=1e-12, atol=1e-12)


def test_a_law_that_cannot_be_loaded_is_an_input_error(tmp_path):
    for spec, words in (("peridyn.no_such_module:law", "cannot be imported"), ("math:sqrt", "not a numba-compiled function")):
        with pytest.raises(InputError, match=words):
            build_simulation(prescribed(np.eye(3), material=dict(LAW, **{"Stress Law": spec})), directory=tmp_path)
    with pytest.raises(Exception, match="module:function"):
        build_simulation(prescribed(np.eye(3), material=dict(LAW, **{"Stress Law": "no_colon"})), directory=tmp_path)
    with pytest.raises(Exception, match="finite"):
        build_simulation(prescribed(np.eye(3), material=dict(LAW, **{"Law Parameters": [MU, float("nan")]})), directory=tmp_path)


COUNTER = '''
import numpy as np
from numba import njit


@njit
def counter(F_old, F_new, state, dt, params):
    """No stress; state[0] counts the steps, state[1] accumulates dt, state[2] holds F_old[0, 0]."""
    out = state.copy()
    out[0] = state[0] + 1.0
    out[1] = state[1] + dt
    out[2] = F_old[0, 0]
    return np.zeros((3, 3)), out
'''


def test_a_law_returning_the_wrong_shapes_is_an_input_error(tmp_path, monkeypatch):
    """A state longer than the 9 columns the material keeps would be written past them."""
    (tmp_path / "peridyn_test_long_state_law.py").write_text(
        "import numpy as np\nfrom numba import njit\n\n\n@njit\ndef law(F_old, F_new, state, dt, params):\n"
        "    return np.zeros((3, 3)), np.zeros(12)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    material = dict(LAW, **{"Stress Law": "peridyn_test_long_state_law:law", "Law Parameters": []})
    with pytest.raises(Exception, match="at most 9 numbers"):
        build_simulation(prescribed(np.eye(3), material=material), directory=tmp_path)


def test_the_state_and_the_old_deformation_gradient_come_from_the_last_step(tmp_path, monkeypatch):
    (tmp_path / "peridyn_test_counter_law.py").write_text(COUNTER)
    monkeypatch.syspath_prepend(str(tmp_path))
    material = dict(LAW, **{"Stress Law": "peridyn_test_counter_law:counter", "Law Parameters": []})
    sim = build_simulation(prescribed(np.diag([1.5, 1.0, 1.0]), material=material, steps=4), directory=tmp_path)
    run_sections(sim)
    state = sim.fields.n("Stress_Law_State")[: sim.num_owned]
    # one call per step on the last step's state (the evaluation before the first step commits nothing)
    assert np.all(state[:, 0] == 4.0) and np.allclose(state[:, 1], 4 * 1.0e-8, rtol=1e-12)
    assert np.allclose(state[:, 2], 1.375, rtol=1e-12)  # F_old of the last call: F at 3/4 of the way
