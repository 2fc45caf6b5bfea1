"""The Short Range Force law: Peridigm's pair law, its order of sums, friction and momentum."""
import math

import numpy as np
import pytest

from peridyn.contact.short_range import PI, ShortRangeForce, ShortRangeForceParams, TimeDependentShortRangeForce, TimeDependentShortRangeForceParams
from peridyn.core.interfaces import ContactPairs, ContactState, VISIT_FROM_PARTNER, VISIT_FROM_POINT
from peridyn.core.errors import InstabilityError


def all_pairs(n, visits=None):
    """Every point lists every other one (rows sorted by gid = index)."""
    offsets = np.arange(0, n * (n - 1) + 1, n - 1, dtype=np.int64)
    partners = np.array([j for i in range(n) for j in range(n) if j != i], dtype=np.int32)
    v = np.full(partners.size, VISIT_FROM_POINT | VISIT_FROM_PARTNER, dtype=np.uint8) if visits is None else visits
    return ContactPairs(offsets, partners, v)


def state(y, v=None, volume=None, horizon=None, block=None):
    n = len(y)
    return ContactState(
        np.asarray(y, float), np.zeros((n, 3)) if v is None else np.asarray(v, float),
        np.ones(n) if volume is None else np.asarray(volume, float),
        np.full(n, 1.0) if horizon is None else np.asarray(horizon, float),
        np.zeros(n, np.int64) if block is None else np.asarray(block, np.int64), np.arange(n, dtype=np.int64), n,
    )


def model(rc=1.0, k=2.0, mu=0.0):
    return ShortRangeForce(ShortRangeForceParams.model_validate({"Contact Radius": rc, "Spring Constant": k, "Friction Coefficient": mu}))


def peridigm_scatter(st, lists, visits_from, rc, k, mu):
    """PERIDIGM_CONTACT.md §4.1-4.3 literally: one accumulator per block, owned points in order,
    node term then neighbour term, blocks summed in order."""
    n = st.num_owned
    nblocks = int(st.block.max()) + 1
    C = np.zeros((nblocks, n, 3))
    for b in range(nblocks):
        for i in range(n):
            if st.block[i] != b:
                continue
            for j in lists[i]:
                if not visits_from(i, j):
                    continue
                a, bb = st.y[i], st.y[j]
                s2 = ((a[0] - bb[0]) ** 2 + (a[1] - bb[1]) ** 2) + (a[2] - bb[2]) ** 2
                if not s2 < rc * rc:
                    continue
                d = math.sqrt(s2)
                delta = st.horizon[i]
                c = (9.0 * k) / ((((PI * delta) * delta) * delta) * delta)
                tau = (c * (rc - d)) / delta
                D = st.y[j] - st.y[i]
                if mu == 0.0:
                    for q in range(3):
                        C[b, i, q] = C[b, i, q] - ((tau * st.volume[j]) * D[q]) / d
                        C[b, j, q] = C[b, j, q] + ((tau * st.volume[i]) * D[q]) / d
                    continue
                nrm = D / d
                ai = (st.v[i, 0] * nrm[0] + st.v[i, 1] * nrm[1]) + st.v[i, 2] * nrm[2]
                aj = (st.v[j, 0] * nrm[0] + st.v[j, 1] * nrm[1]) + st.v[j, 2] * nrm[2]
                pi_ = st.v[i] - ai * nrm
                pj = st.v[j] - aj * nrm
                m = 0.5 * (pi_ + pj)
                ri, rj = pi_ - m, pj - m
                Ni = -(((tau * st.volume[j]) * D) / d)
                Nj = ((tau * st.volume[i]) * D) / d
                for r, N, tgt in ((ri, Ni, i), (rj, Nj, j)):
                    rn = math.sqrt((r[0] * r[0] + r[1] * r[1]) + r[2] * r[2])
                    nn = math.sqrt((N[0] * N[0] + N[1] * N[1]) + N[2] * N[2])
                    T = (((-mu) * nn) * r) / rn if rn != 0.0 else np.zeros(3)
                    for q in range(3):
                        C[b, tgt, q] = C[b, tgt, q] + (N[q] + T[q])
    out = np.zeros((n, 3))
    for b in range(nblocks):
        out = out + C[b]
    return out


def test_two_points_follow_the_net_pair_law():
    rc, k, delta, d = 1.0, 3.0, 2.0, 0.6
    st = state([[0, 0, 0], [d, 0, 0]], volume=[2.0, 5.0], horizon=[delta, delta])
    out = np.zeros((2, 3))
    model(rc, k).force(all_pairs(2), st, out)
    expected = (18 * k / (math.pi * delta**4)) * ((rc - d) / delta)
    assert out[0, 0] == pytest.approx(-expected * 5.0, rel=1e-14)  # carries the other point's volume
    assert out[1, 0] == pytest.approx(expected * 2.0, rel=1e-14)
    assert np.all(out[:, 1:] == 0.0)


def test_no_force_at_or_beyond_the_contact_radius():
    st = state([[0, 0, 0], [1.0, 0, 0], [0, 1.5, 0]])
    out = np.zeros((3, 3))
    model(rc=1.0).force(all_pairs(3), st, out)
    assert np.all(out == 0.0)  # strict: exactly R_c apart is not in contact


@pytest.mark.parametrize("mu", [0.0, 0.4])
def test_sums_are_peridigms_to_the_bit_and_conserve_momentum(mu):
    rng = np.random.default_rng(3)
    n = 14
    y = rng.uniform(0, 1.2, (n, 3))
    v = rng.normal(size=(n, 3))
    vol = rng.uniform(0.5, 2.0, n)
    block = (np.arange(n) % 3 == 0).astype(np.int64)  # two interleaved blocks, one horizon
    st = state(y, v, vol, np.full(n, 1.3), block)
    out = np.zeros((n, 3))
    model(rc=0.7, k=5.0, mu=mu).force(all_pairs(n), st, out)
    lists = [[j for j in range(n) if j != i] for i in range(n)]
    ref = peridigm_scatter(st, lists, lambda i, j: True, 0.7, 5.0, mu)
    assert np.array_equal(out, ref)
    assert np.any(out != 0.0)
    total = (out * vol[:, None]).sum(axis=0)
    assert np.abs(total).max() <= 1e-12 * np.abs(out * vol[:, None]).sum()


def test_one_sided_visits_follow_each_points_bond_list():
    rng = np.random.default_rng(5)
    n = 8
    y = rng.uniform(0, 1.0, (n, 3))
    st = state(y, volume=rng.uniform(0.5, 2, n), horizon=np.where(np.arange(n) < 4, 1.0, 1.5), block=(np.arange(n) >= 4).astype(np.int64))
    excluded = {(0, 5), (2, 6), (6, 1)}  # i holds j in its bond list: the visit i -> j does not exist
    pairs = all_pairs(n)
    vis = []
    for i in range(n):
        for j in range(n):
            if j != i:
                vis.append((0 if (i, j) in excluded else VISIT_FROM_POINT) | (0 if (j, i) in excluded else VISIT_FROM_PARTNER))
    pairs.visits = np.array(vis, np.uint8)
    out = np.zeros((n, 3))
    model(rc=0.9, k=1.0).force(pairs, st, out)
    lists = [[j for j in range(n) if j != i] for i in range(n)]
    ref = peridigm_scatter(st, lists, lambda i, j: (i, j) not in excluded, 0.9, 1.0, 0.0)
    assert np.array_equal(out, ref)


def test_friction_opposes_the_relative_sliding_with_mu_times_the_normal_force():
    mu = 0.3
    st = state([[0, 0, 0], [0, 0.5, 0]], v=[[2.0, 0, 0], [-2.0, 0, 0]])
    out = np.zeros((2, 3))
    model(rc=1.0, k=1.0, mu=mu).force(all_pairs(2), st, out)
    assert out[0, 0] < 0 < out[1, 0]
    assert abs(out[0, 0]) == pytest.approx(mu * abs(out[0, 1]), rel=1e-12)
    same = state([[0, 0, 0], [0, 0.5, 0]], v=[[2.0, 0, 0], [2.0, 0, 0]])  # no sliding: no friction
    out2 = np.zeros((2, 3))
    model(rc=1.0, k=1.0, mu=mu).force(all_pairs(2), same, out2)
    assert np.all(out2[:, 0] == 0.0)


def test_time_dependent_friction_is_evaluated_at_the_step_time():
    p = TimeDependentShortRangeForceParams.model_validate({"Contact Radius": 1.0, "Spring Constant": 1.0, "Friction Coefficient": "0.1*t"})
    m = TimeDependentShortRangeForce(p)
    assert m.mu == 0.0  # t = 0 at construction
    m.begin_step(2.0)
    assert m.mu == pytest.approx(0.2)
    bad = TimeDependentShortRangeForce(TimeDependentShortRangeForceParams.model_validate(
        {"Contact Radius": 1.0, "Spring Constant": 1.0, "Friction Coefficient": "1/(2-t)"}))
    with pytest.raises(InstabilityError, match="friction coefficient"):
        bad.begin_step(2.0)


def test_potential_energy_is_minus_the_integral_of_the_force():
    m = model(rc=1.0, k=2.0)
    d, h = 0.6, 1e-6

    def energy(dist):
        st = state([[0, 0, 0], [dist, 0, 0]], volume=[1.5, 0.5])
        return m.potential_energy(all_pairs(2), st)

    st = state([[0, 0, 0], [d, 0, 0]], volume=[1.5, 0.5])
    out = np.zeros((2, 3))
    m.force(all_pairs(2), st, out)
    force_on_1 = out[1, 0] * 0.5  # force = force density x volume
    assert -(energy(d + h) - energy(d - h)) / (2 * h) == pytest.approx(force_on_1, rel=1e-6)
