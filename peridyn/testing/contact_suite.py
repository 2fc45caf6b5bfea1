"""The conformance suite for contact models: subclass :class:`ContactConformance`.

The checks call the model directly on small point clouds (no engine): parameters validate by
their deck names; no force beyond the contact radius; repulsion within it; linear momentum
(with sliding velocities, so friction is exercised) and, without sliding, angular momentum;
forces that are minus the gradient of the reported potential energy; and rows that can be
computed apart (a rank that owns some points and sees the others as ghosts gets the same
forces, bit for bit: the model gathers and never writes to another point).
"""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from ..core.interfaces import VISIT_FROM_PARTNER, VISIT_FROM_POINT, ContactPairs, ContactState
from .harness import isolated_registry


def _pairs(y: np.ndarray, radius: float, rows: np.ndarray | None = None) -> tuple[ContactPairs, np.ndarray]:
    """Every pair closer than ``radius``, rows for the points ``rows`` (default all), partners
    by index, sorted."""
    n = y.shape[0]
    rows = np.arange(n) if rows is None else rows
    d = np.linalg.norm(y[None, :, :] - y[rows, None, :], axis=-1)
    lists = [np.flatnonzero((d[k] <= radius) & (np.arange(n) != r)) for k, r in enumerate(rows)]
    offsets = np.concatenate([[0], np.cumsum([len(x) for x in lists])]).astype(np.int64)
    partners = np.concatenate(lists).astype(np.int32) if lists else np.zeros(0, np.int32)
    visits = np.full(partners.size, VISIT_FROM_POINT | VISIT_FROM_PARTNER, dtype=np.uint8)
    return ContactPairs(offsets, partners, visits), partners


class ContactConformance:
    """Checks for a contact model. Set ``contact_model`` (deck name), ``params`` and
    optionally ``plugins`` (modules with the hooks, for a model not yet installed) and
    ``horizon`` (the blocks' horizon the checks use, L)."""

    contact_model: ClassVar[str] = ""
    params: ClassVar[dict[str, Any]] = {}
    plugins: ClassVar[tuple] = ()
    horizon: ClassVar[float] = 1.5

    # -- helpers ------------------------------------------------------------------------------
    def model(self, params: dict[str, Any] | None = None):
        from ..plugins.manager import get_registry

        if self.plugins:
            with isolated_registry(*self.plugins) as reg:
                cls = reg.get("contact", self.contact_model)
        else:
            cls = get_registry().get("contact", self.contact_model)
        return cls(cls.Params.model_validate({**self.params, **(params or {})}))

    def cloud(self, n: int = 40, seed: int = 0, sliding: bool = True) -> ContactState:
        """n points scattered in a box about 2.5 contact radii wide, random volumes (and
        velocities when ``sliding``)."""
        m = self.model()
        rng = np.random.default_rng(seed)
        r = m.contact_radius
        y = rng.uniform(0.0, 2.5 * r, (n, 3))
        v = rng.normal(size=(n, 3)) if sliding else np.zeros((n, 3))
        volume = rng.uniform(0.5, 1.5, n) * (0.3 * r) ** 3
        return ContactState(y, v, volume, np.full(n, self.horizon * r), np.zeros(n, np.int64), np.arange(n, dtype=np.int64), n)

    def forces(self, model, state: ContactState, pairs: ContactPairs | None = None) -> np.ndarray:
        pairs = pairs if pairs is not None else _pairs(state.y, 1.5 * model.contact_radius)[0]
        out = np.zeros((state.num_owned, 3))
        model.force(pairs, state, out)
        return out

    # -- checks -------------------------------------------------------------------------------
    def test_params_validate(self):
        m = self.model()
        assert m.contact_radius > 0
        assert type(m).Params.model_validate(self.params) == m.params

    def test_no_force_beyond_the_contact_radius(self):
        m = self.model()
        r = m.contact_radius
        y = np.array([[0.0, 0.0, 0.0], [1.01 * r, 0.0, 0.0], [0.0, 3.0 * r, 0.0]])
        st = ContactState(y, np.ones((3, 3)), np.ones(3), np.full(3, self.horizon * r), np.zeros(3, np.int64), np.arange(3, dtype=np.int64), 3)
        assert np.all(self.forces(m, st, _pairs(y, 10 * r)[0]) == 0.0)

    def test_close_points_are_pushed_apart(self):
        m = self.model()
        r = m.contact_radius
        y = np.array([[0.0, 0.0, 0.0], [0.5 * r, 0.0, 0.0]])
        st = ContactState(y, np.zeros((2, 3)), np.ones(2), np.full(2, self.horizon * r), np.zeros(2, np.int64), np.arange(2, dtype=np.int64), 2)
        f = self.forces(m, st)
        assert f[0, 0] < 0.0 < f[1, 0]
        assert np.allclose(f[:, 1:], 0.0)

    def test_linear_momentum_is_conserved(self):
        m = self.model()
        st = self.cloud()
        f = self.forces(m, st) * st.volume[:, None]
        assert np.abs(f).sum() > 0, "no pair of the test cloud interacted"
        assert np.abs(f.sum(axis=0)).max() <= 1e-12 * np.abs(f).sum()

    def test_angular_momentum_is_conserved_without_sliding(self):
        m = self.model()
        st = self.cloud(sliding=False)
        f = self.forces(m, st) * st.volume[:, None]
        torque = np.cross(st.y, f).sum(axis=0)
        assert np.abs(torque).max() <= 1e-11 * np.abs(np.cross(st.y, f)).sum()

    def test_force_is_minus_the_gradient_of_the_energy(self):
        m = self.model()
        st = self.cloud(n=12, seed=2, sliding=False)
        pairs = _pairs(st.y, 1.5 * m.contact_radius)[0]
        e0 = m.potential_energy(pairs, st)
        if e0 is None:
            return  # the model reports no energy
        f = self.forces(m, st, pairs) * st.volume[:, None]
        k = int(np.argmax(np.abs(f).sum(axis=1)))
        h = 1e-6 * m.contact_radius
        for c in range(3):
            plus, minus = st.y.copy(), st.y.copy()
            plus[k, c] += h
            minus[k, c] -= h
            ep = m.potential_energy(pairs, ContactState(plus, st.v, st.volume, st.horizon, st.block, st.gid, st.num_owned))
            em = m.potential_energy(pairs, ContactState(minus, st.v, st.volume, st.horizon, st.block, st.gid, st.num_owned))
            assert abs(-(ep - em) / (2 * h) - f[k, c]) <= 1e-5 * np.abs(f[k]).max()

    def test_rows_can_be_computed_apart(self):
        """Owned points first, the others as ghosts: the owned rows' forces are the same."""
        m = self.model()
        st = self.cloud(seed=4)
        full = self.forces(m, st)
        owned = np.arange(0, st.num_owned, 2)
        order = np.concatenate([owned, np.setdiff1d(np.arange(st.num_owned), owned)])
        inverse = np.empty_like(order)
        inverse[order] = np.arange(order.size)
        part = ContactState(st.y[order], st.v[order], st.volume[order], st.horizon[order], st.block[order], st.gid[order], owned.size)
        pairs, _ = _pairs(part.y, 1.5 * m.contact_radius, rows=np.arange(owned.size))
        # rows sorted by global id, as the engine gives them
        for i in range(owned.size):
            lo, hi = pairs.offsets[i], pairs.offsets[i + 1]
            pairs.partners[lo:hi] = pairs.partners[lo:hi][np.argsort(part.gid[pairs.partners[lo:hi]], kind="stable")]
        out = np.zeros((owned.size, 3))
        m.force(pairs, part, out)
        assert np.array_equal(out, full[owned])
