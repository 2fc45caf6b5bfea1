"""The material-family problems of ``peridyn verify`` (``diffusion``, ``viscoelastic-relaxation``,
``plasticity-uniaxial``): their quick ladders land in their bands, and the bands catch wrong
physics (a diffusivity, relaxation time, yield stress or hardening modulus off)."""
import math

import pytest

from peridyn.verify.problems.families import FAMILIES, Diffusion, PlasticityUniaxial, ViscoelasticRelaxation
from peridyn.verify.runner import Run

from .test_contact_verify import failed, ladder


def test_every_problem_is_described():
    for cls in FAMILIES:
        p = cls()
        assert p.computes and p.reference and p.methods
        for method in p.methods:
            quick, full = p.ladder(method, True), p.ladder(method, False)
            assert len(quick) >= 3 and quick == sorted(quick) and full[: len(quick)] == quick and len(full) >= len(quick)
            # a rate band where the error converges, otherwise per-point bands and a reason
            assert (method in p.rate_band) != (method in p.unfitted), method
            assert method in p.rate_band or method in p.every_band


# -- diffusion ------------------------------------------------------------------------------------
@pytest.mark.parametrize("method", ["decay, improved quadrature", "decay, plain quadrature"])
def test_diffusion_decay_rate_converges_to_the_heat_equation(method):
    p = Diffusion()
    points, checks = ladder(p, method)
    assert not failed(checks), failed(checks)
    assert 1.8 < p.rate(points) < 2.3
    errors = [q["error"] for q in points]
    assert all(b < a / 3.0 for a, b in zip(errors, errors[1:])), errors
    c = 1.0 if method.endswith("improved quadrature") else 1.0987  # the plain lattice weights: a diffusivity 9.9 % too large
    assert points[-1]["values"]["c (family)"] == pytest.approx(c, abs=1e-4)
    assert points[-1]["values"]["s/(kappa k^2)"] == pytest.approx(c, abs=5e-3)


def test_diffusion_steady_state_converges_at_second_order():
    p = Diffusion()
    points, checks = ladder(p, "steady state")
    assert not failed(checks), failed(checks)
    assert points[-1]["error"] < p.finest_band["steady state"]


def test_a_wrong_diffusivity_fails_the_decay_but_not_the_steady_state(monkeypatch):
    """kappa 10 % too large: the decay rate is 10 % off at every resolution (finest band and rate
    fail); a steady state does not depend on the diffusivity's size."""
    from peridyn.materials.diffusion import Diffusion as DiffusionMaterial

    init = DiffusionMaterial.__init__

    def wrong(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.kappa *= 1.1

    p = Diffusion()
    steady_before = p.measure("steady state", 24.0, True).error
    monkeypatch.setattr(DiffusionMaterial, "__init__", wrong)
    points, checks = ladder(p, "decay, improved quadrature")
    assert points[-1]["error"] == pytest.approx(0.1, abs=0.01)
    assert {"fitted rate" in c.what for c in failed(checks)} == {True, False}, failed(checks)  # the finest error and the rate
    assert p.measure("steady state", 24.0, True).error == pytest.approx(steady_before, rel=1e-6)


# -- viscoelasticity ------------------------------------------------------------------------------
def test_viscoelastic_relaxation_quick_ladder_passes():
    p = ViscoelasticRelaxation()
    points, checks = ladder(p, "Viscoelastic")
    assert not failed(checks), failed(checks)
    assert 0.9 < p.rate(points) < 1.1
    for q in points:
        assert q["values"]["error against G_dt"] < 1e-9  # the update is exact for strains linear over a step
        assert q["values"]["mu_eff/mu"] == pytest.approx(1.110, abs=1e-3)  # the lattice's cubic anisotropy
        assert q["values"]["G at the end"] == pytest.approx(0.3 + 0.7 * math.exp(-5.0), abs=2.0 * q["error"])


def test_a_wrong_relaxation_time_fails(monkeypatch):
    from peridyn.materials.deviatoric import relaxation_constants
    from peridyn.materials.viscoelastic import Viscoelastic

    monkeypatch.setattr(Viscoelastic, "_constants", lambda self, block: relaxation_constants(1.1 * float(self.params.tau_b), float(block.time_step)))
    p = ViscoelasticRelaxation()
    points, checks = ladder(p, "Viscoelastic")
    assert points[-1]["error"] > p.finest_band["Viscoelastic"]
    assert len(failed(checks)) == len(checks), checks  # every point off G_dt, the finest error and the rate


def test_viscoelastic_runs_through_the_runner(tmp_path):
    run = Run([ViscoelasticRelaxation()], tmp_path, quick=True, command="test")
    assert run.run() == 0
    entry = run.state["problems"][0]
    assert entry["name"] == "viscoelastic-relaxation" and len(entry["points"]) == 4
    assert all(c["passed"] for c in entry["checks"])
    assert (tmp_path / "report.md").is_file() and "viscoelastic-relaxation" in (tmp_path / "report.md").read_text()


# -- plasticity -----------------------------------------------------------------------------------
@pytest.mark.parametrize("method", PlasticityUniaxial.methods)
def test_plasticity_quick_ladder_passes(method):
    p = PlasticityUniaxial()
    points, checks = ladder(p, method)
    assert not failed(checks), failed(checks)
    last = points[-1]["values"]
    assert last["plastic steps"] > 0.5 * points[-1]["resolution"]  # the curve did yield
    if method == "Elastic Plastic":
        assert last["sigma(eps_max)/sigma_y"] == pytest.approx(0.9715, abs=1e-4)  # the lattice's plateau
    else:
        assert 0.9 < p.rate(points) < 1.15
        assert last["sigma(eps_max)/sigma_y"] > 1.3  # it hardened


def test_a_wrong_yield_stress_fails_perfect_plasticity(monkeypatch):
    """sigma_y 5 % too large (Y 10.25 %): the plateau is 5 % off, far outside the 2e-5 band."""
    from peridyn.materials.elastic_plastic import ElasticPlastic

    init = ElasticPlastic.__init__

    def wrong(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.Y *= 1.05**2

    monkeypatch.setattr(ElasticPlastic, "__init__", wrong)
    p = PlasticityUniaxial()
    points, checks = ladder(p, "Elastic Plastic", [20.0])
    assert points[0]["error"] == pytest.approx(0.05 * 0.9715, rel=0.02)
    assert failed(checks) and all("stress error" in c.what for c in failed(checks))


def test_a_wrong_hardening_modulus_fails(monkeypatch):
    from peridyn.materials.elastic_plastic_hardening import ElasticPlasticHardening

    init = ElasticPlasticHardening.__init__

    def wrong(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.H *= 1.5

    monkeypatch.setattr(ElasticPlasticHardening, "__init__", wrong)
    p = PlasticityUniaxial()
    points, checks = ladder(p, "Elastic Plastic Hardening")
    assert points[-1]["error"] > 10 * p.finest_band["Elastic Plastic Hardening"]
    assert {"fitted rate" in c.what for c in failed(checks)} == {True, False}  # the finest error and the rate
