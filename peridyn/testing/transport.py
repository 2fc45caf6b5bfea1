"""The conformance suite for transport materials (a scalar field and its flux divergence, such as
``Diffusion``): subclass :class:`TransportConformance`.

    class TestMyDiffusion(TransportConformance):
        material = "My Diffusion"
        params = {"Coefficient": 2.5}

Checks, on PdQuickGrid boxes built in memory:

* a uniform field gives no flux anywhere (the analogue of rigid motion);
* the flux of any field is conservative: sum_i Q_i V_i = 0 (every bond's exchange enters both
  ends with opposite signs; the analogue of momentum balance), unless ``conservative = False``;
* a linear field gives no flux at points whose family is complete (first-order consistency);
* the flux is linear in the field where the model says it is (``linear = True``): Q(a T1 + b T2)
  = a Q(T1) + b Q(T2);
* the result does not depend on the number of threads beyond round-off;
* a non-finite field value stops the evaluation instead of spreading NaN.

``field`` and ``flux`` name the material's input and output fields (node scalars).
"""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from .harness import build_simulation, cube_deck


class TransportConformance:
    material: ClassVar[str] = ""
    params: ClassVar[dict[str, Any]] = {}
    field: ClassVar[str] = "Temperature"
    flux: ClassVar[str] = "Flux_Divergence"
    linear: ClassVar[bool] = True
    #: False for a quadrature that trades conservation for accuracy (weights that differ at the
    #: two ends of a bond, e.g. Diffusion's improved quadrature)
    conservative: ClassVar[bool] = True
    #: points per direction, spacing and horizon / spacing of the test boxes
    shape: ClassVar[tuple[int, int, int]] = (9, 9, 9)
    spacing: ClassVar[float] = 1.0
    horizon_factor: ClassVar[float] = 3.015

    # -- helpers --------------------------------------------------------------------------------
    def build(self, shape: tuple[int, int, int] | None = None):
        material = {"Material Model": self.material, **self.params}
        return build_simulation(cube_deck(material, shape=shape or self.shape, spacing=self.spacing, horizon_factor=self.horizon_factor))

    def evaluate(self, sim, values: np.ndarray) -> np.ndarray:
        n = sim.num_owned
        sim.fields[self.field][:n] = values
        sim.evaluate_forces()
        return np.array(sim.fields[self.flux][:n])

    @staticmethod
    def scale(Q: np.ndarray) -> float:
        return float(np.abs(Q).max()) or 1.0

    def interior(self, sim) -> np.ndarray:
        """Points at least one horizon inside every face (complete families)."""
        x = sim.fields["Model_Coordinates"][: sim.num_owned]
        lo, hi = x.min(axis=0), x.max(axis=0)
        d = self.horizon_factor * self.spacing
        return np.all((x - lo >= d - 1e-9 * self.spacing) & (hi - x >= d - 1e-9 * self.spacing), axis=1)

    # -- the checks -----------------------------------------------------------------------------
    def test_uniform_field_gives_no_flux(self):
        sim = self.build()
        Q = self.evaluate(sim, np.full(sim.num_owned, 273.15))
        assert np.all(np.abs(Q) == 0.0), f"largest flux {np.abs(Q).max():.3g} for a uniform field"

    def test_flux_is_conservative(self):
        import pytest
        if not self.conservative:
            pytest.skip("the model's quadrature is not conservative")
        sim = self.build(shape=(5, 6, 4))
        n = sim.num_owned
        V = sim.fields["Volume"][:n]
        Q = self.evaluate(sim, 300.0 + np.random.default_rng(3).standard_normal(n))
        total = float(np.dot(Q, V))
        assert abs(total) <= 1e-12 * float(np.abs(Q * V).sum()), f"sum Q V = {total:.3g}"

    def test_linear_field_gives_no_flux_where_families_are_complete(self):
        sim = self.build()
        x = sim.fields["Model_Coordinates"][: sim.num_owned]
        inner = self.interior(sim)
        assert inner.any(), "the test box has no point with a complete family; enlarge shape"
        Q = self.evaluate(sim, 2.0 * x[:, 0] - 0.5 * x[:, 1] + 0.25 * x[:, 2] + 10.0)
        ref = self.scale(self.evaluate(sim, x[:, 0] ** 2))  # the size of a non-trivial flux
        assert np.abs(Q[inner]).max() <= 1e-10 * ref

    def test_flux_is_linear_in_the_field(self):
        import pytest
        if not self.linear:
            pytest.skip("the model is not linear in its field")
        sim = self.build(shape=(5, 5, 5))
        rng = np.random.default_rng(5)
        n = sim.num_owned
        T1, T2 = rng.standard_normal(n), rng.standard_normal(n)
        Q1, Q2 = self.evaluate(sim, T1), self.evaluate(sim, T2)
        Q = self.evaluate(sim, 2.0 * T1 - 3.0 * T2)
        np.testing.assert_allclose(Q, 2.0 * Q1 - 3.0 * Q2, rtol=0, atol=1e-12 * self.scale(Q))

    def test_result_does_not_depend_on_the_thread_count(self):
        import numba

        sim = self.build(shape=(6, 5, 5))
        values = 300.0 + np.random.default_rng(7).standard_normal(sim.num_owned)
        before = numba.get_num_threads()
        try:
            numba.set_num_threads(1)
            one = self.evaluate(sim, values)
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
            many = self.evaluate(sim, values)
        finally:
            numba.set_num_threads(before)
        np.testing.assert_allclose(many, one, rtol=0, atol=1e-13 * self.scale(one))

    def test_non_finite_field_stops(self):
        import pytest
        from ..core.errors import InstabilityError

        sim = self.build(shape=(3, 3, 3))
        values = np.ones(sim.num_owned)
        values[4] = np.nan
        with pytest.raises(InstabilityError):
            self.evaluate(sim, values)
