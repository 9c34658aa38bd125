"""rho_H (2.9) on point clouds: exact gradients, symmetry, limits, bias, extremes, MPI."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import rank_share, taylor_in_points
from mpi4py import MPI

from shapegrowth.optim.taylor import taylor_test
from shapegrowth.shape.hausdorff import PointCloud, SmoothHausdorff, exact_hausdorff

ROOT = Path(__file__).resolve().parents[1]

RNG = np.random.default_rng(11)


def clouds(n=300, m=250, dim=3, gap=0.02):
    """Two overlapping random clouds with no pair closer than ``gap``: at coincident
    points |x - y| has a kink, and so has rho_H."""
    from scipy.spatial import cKDTree

    a_pts = RNG.random((n, dim))
    b_pts = RNG.random((3 * m, dim)) + np.eye(dim)[0] * 0.3
    b_pts = b_pts[cKDTree(a_pts).query(b_pts)[0] > gap][:m]
    return (PointCloud(a_pts, RNG.uniform(0.5, 1.5, n)),
            PointCloud(b_pts, RNG.uniform(0.5, 1.5, len(b_pts))))


def grid_square(n=41):
    g = np.linspace(0, 1, n)
    X, Y = np.meshgrid(g, g)
    pts = np.column_stack([X.ravel(), Y.ravel()])
    return PointCloud(pts, np.full(len(pts), 1.0 / len(pts)))


@pytest.mark.parametrize("phi", ["exp", "rational"])
@pytest.mark.parametrize("truncate", [False, True])
@pytest.mark.parametrize("dim", [2, 3])
def test_taylor_in_points_and_weights(phi, truncate, dim):
    a, b = clouds(dim=dim)
    H = SmoothHausdorff(alpha=20.0, beta=2.0, gamma=3.0, phi=phi, truncate=truncate)
    n = len(a.weights)
    dp, dw = 0.05 * RNG.standard_normal((n, dim)), 0.05 * RNG.standard_normal(n)

    def J(m):
        return H(PointCloud(a.points + m[:n * dim].reshape(n, dim), a.weights + m[n * dim:]), b,
                 gradient=False).value

    def dJ(m):
        r = H(PointCloud(a.points + m[:n * dim].reshape(n, dim), a.weights + m[n * dim:]), b)
        return np.concatenate([r.grad_points.ravel(), r.grad_weights])

    result = taylor_test(J, dJ, np.zeros(n * dim + n), np.concatenate([dp.ravel(), dw]),
                         eps0=1e-3, steps=4)
    assert result.min_rate > 1.9, result.rates


def test_vectorised_exp_matches_libm():
    """The kernels' exp (Taylor polynomial after range reduction, 2^n built in the bits)
    against numpy's on the clamped range [-100, 0] and at its ends."""
    from shapegrowth.shape.kernels import exp_array

    x = np.concatenate([-100.0 * RNG.random(100000), np.linspace(-100.0, 0.0, 20001),
                        [0.0, -0.0, -1e-300, -100.0]])
    assert np.max(np.abs(exp_array(x) / np.exp(x) - 1.0)) < 1e-15


@pytest.mark.parametrize("cell", [None, 0.03, 0.2])
def test_grid_nearest_distances_are_the_kd_tree_ones(cell):
    from scipy.spatial import cKDTree

    from shapegrowth.shape import cellgrid

    sources = RNG.random((5000, 3)) * [1.0, 0.3, 0.05]
    queries = RNG.random((3000, 3)) * [1.6, 0.8, 0.6] - [0.3, 0.2, 0.3]
    grid = cellgrid.SourceGrid.build(sources, np.ones(len(sources)), cell)
    near = cellgrid.nearest_distance(queries, grid.xyz, grid.origin, grid.cell, grid.shape,
                                     grid.start)
    assert np.allclose(near, cKDTree(sources).query(queries)[0], rtol=1e-15, atol=0)  # 1 ulp


def test_nearest_search_on_its_own_grid_is_the_kd_tree_one():
    """The search's grid of a few source spacings, each query's ball bounded by the distance
    to the nearest source of the query before it: in locality order (close bounds) and in
    random order (loose ones), the KD-tree's distances and a source at that distance."""
    from scipy.spatial import cKDTree

    from shapegrowth.shape import cellgrid

    rng = np.random.default_rng(8)  # its own: the module's draws stay the other tests'
    sources = rng.random((20000, 3)) * [1.0, 0.1, 0.02]
    queries = rng.random((4000, 3)) * [1.4, 0.5, 0.6] - [0.2, 0.2, 0.3]
    cell = cellgrid.search_cell(sources)
    assert cell is not None and cell < 0.05
    grid = cellgrid.SourceGrid.build(sources, np.ones(len(sources)), cell)
    for q in (queries[grid.locality_order(queries)], queries):
        q = np.ascontiguousarray(q)
        near, index = cellgrid.nearest_source(q, grid.xyz, grid.origin, grid.cell, grid.shape,
                                              grid.start)
        assert np.allclose(near, cKDTree(sources).query(q)[0], rtol=1e-15, atol=0)
        found = sources[grid.order[index]]
        assert np.allclose(np.linalg.norm(q - found, axis=1), near, rtol=1e-15, atol=0)


@pytest.mark.parametrize("truncate", [False, True])
def test_exact_hausdorff_comes_with_rho(truncate):
    a, b = clouds(4000, 3000)
    result = SmoothHausdorff(alpha=300.0, truncate=truncate)(a, b)
    assert result.hausdorff == pytest.approx(exact_hausdorff(a, b), rel=1e-15)


def test_a_kept_target_gives_the_numbers_of_a_fresh_one():
    """The target's gathered points and KD-tree are built once and kept."""
    a, b = clouds()
    H = SmoothHausdorff(alpha=30.0)
    first = H(a, b)
    again = H(PointCloud(a.points.copy(), a.weights.copy()), b)
    fresh = H(a, PointCloud(b.points.copy(), b.weights.copy()))
    assert first.value == again.value == fresh.value
    assert np.array_equal(again.grad_points, fresh.grad_points)


def test_symmetric_in_its_arguments():
    a, b = clouds()
    H = SmoothHausdorff(alpha=30.0, beta=3.0, gamma=1.5)
    assert H(a, b, gradient=False).value == pytest.approx(H(b, a, gradient=False).value,
                                                          rel=1e-14)


@pytest.mark.parametrize("cutoff, rel", [(20.0, 1e-7), (40.0, 1e-13)])
def test_truncation_error_is_set_by_the_cutoff(cutoff, rel):
    """Terms fade out over the two e-folds before the cutoff: below exp(-18) = 1.5e-8 of the
    nearest at cutoff 20, exp(-38) = 3e-17 at 40, against the whole sum (no cutoff)."""
    a, b = clouds(4000, 3000)
    whole = SmoothHausdorff(alpha=300.0, truncate=False, cutoff=np.inf)(a, b)
    grid = SmoothHausdorff(alpha=300.0, truncate=True, cutoff=cutoff)(a, b)
    assert grid.truncated and not whole.truncated
    assert grid.value == pytest.approx(whole.value, rel=rel)
    scale = np.abs(whole.grad_points).max()
    assert np.allclose(grid.grad_points, whole.grad_points, rtol=100 * rel, atol=rel * scale)
    scale = np.abs(whole.grad_weights).max()
    assert np.allclose(grid.grad_weights, whole.grad_weights, rtol=100 * rel, atol=rel * scale)


@pytest.mark.parametrize("phi", ["exp", "rational"])
def test_the_grid_prunes_only_what_the_taper_removes(phi):
    """With a short cutoff the taper changes rho_H, and the grid, which skips the pairs
    beyond it, gives the brute force's numbers with the same taper to round-off."""
    a, b = clouds(4000, 3000)
    brute = SmoothHausdorff(alpha=300.0, truncate=False, cutoff=6.0, phi=phi)(a, b)
    grid = SmoothHausdorff(alpha=300.0, truncate=True, cutoff=6.0, phi=phi)(a, b)
    whole = SmoothHausdorff(alpha=300.0, truncate=False, cutoff=np.inf, phi=phi)(a, b)
    assert grid.truncated
    assert abs(grid.value / whole.value - 1.0) > 1e-6  # the taper does change it
    assert grid.value == pytest.approx(brute.value, rel=1e-13)
    for g, f in [(grid.grad_points, brute.grad_points), (grid.grad_weights,
                                                         brute.grad_weights)]:
        assert np.allclose(g, f, rtol=1e-10, atol=1e-12 * np.abs(f).max())


def test_taper_is_a_differentiable_step():
    """S = 1 up to cut - width, 0 from cut, monotone, S' continuous at both ends (zero
    there), and the kernels' -dS/du against central differences of S."""
    from shapegrowth.shape.kernels import taper_array

    cut, width = 8.0, 2.0
    u = np.linspace(4.0, 10.0, 6001)
    S, dS = taper_array(u, cut, width)
    assert np.all(S[u <= cut - width] == 1.0) and np.all(S[u >= cut] == 0.0)
    assert np.all(np.diff(S) <= 0.0)
    h = 1e-6
    fd = -(taper_array(u + h, cut, width)[0] - taper_array(u - h, cut, width)[0]) / (2 * h)
    assert np.allclose(dS, fd, atol=1e-6)  # 3h/8 at the ends, where S'' jumps
    ends = np.array([cut - width, cut])
    assert np.all(taper_array(ends, cut, width)[1] == 0.0)
    assert np.all(taper_array(ends + 1e-6, cut, width)[1] < 1e-5)
    assert np.all(taper_array(ends - 1e-6, cut, width)[1] < 1e-5)


@pytest.mark.parametrize("phi", ["exp", "rational"])
def test_taylor_with_a_short_cutoff(phi):
    """A short cutoff moves with each query's nearest source: its gradient is still exact."""
    a, b = clouds(dim=3)
    H = SmoothHausdorff(alpha=60.0, beta=2.0, gamma=3.0, phi=phi, truncate=True, cutoff=4.0,
                        taper=2.0)
    dp = 0.05 * RNG.standard_normal((len(a.weights), 3))
    result = taylor_in_points(H, a, b, dp, eps0=1e-3)
    assert result.min_rate > 1.9, result.rates


def test_soft_distance_converges_like_log_alpha_over_alpha():
    """Measured error of the soft distance of a point to a 41x41 grid: 2.8e-1, 5.5e-2,
    6.7e-3, 7.4e-4 at alpha = 10, 100, 1000, 10000 (slopes 0.71, 0.91, 0.96 per decade)."""
    square = grid_square()
    q = np.array([[1.4, 0.5]])
    true = float(np.min(np.linalg.norm(square.points - q, axis=1)))
    errors = [SmoothHausdorff(alpha=alpha).soft_distance(q, square)[0] - true
              for alpha in (10.0, 100.0, 1000.0, 10000.0)]
    assert all(e > 0 for e in errors)  # never below the true distance
    slopes = -np.diff(np.log10(errors))
    assert slopes[-1] > 0.9 and all(slopes > 0.6), slopes


def test_rho_tends_to_hausdorff_as_alpha_beta_gamma_grow():
    """beta, gamma fixed: rho_H tends to L^beta means of the distance functions, not to
    their maximum; growing all three: 0.23, 0.19, 0.14, 0.096, 0.056 away from d_H."""
    a = grid_square()
    b = PointCloud(a.points * [1.0, 0.5] + [0.3, 0.0], a.weights)
    d_h = exact_hausdorff(a, b)
    assert d_h == pytest.approx(np.hypot(0.3, 0.5), rel=1e-12)
    errors = [abs(SmoothHausdorff(alpha=100.0 * s, beta=4.0 * s, gamma=4.0 * s)(
        a, b, gradient=False).value - d_h) for s in (1, 2, 4, 8, 16)]
    assert all(np.diff(errors) < 0) and errors[-1] < 0.1 * d_h, errors


def test_bias_on_identical_clouds():
    """rho_H(A, A) > 0, about 10.5/alpha on the 41x41 grid once alpha exceeds 1/spacing:
    0.44, 0.099, 0.0105, 0.00105 at alpha = 10, 100, 1000, 10000."""
    a = grid_square()
    bias = [SmoothHausdorff(alpha=alpha)(a, a, gradient=False).value
            for alpha in (10.0, 100.0, 1000.0, 10000.0)]
    assert all(b > 0 for b in bias)
    assert bias[2] * 1000.0 == pytest.approx(10.5, rel=0.02)
    assert bias[3] * 10000.0 == pytest.approx(10.5, rel=0.02)


@pytest.mark.parametrize("phi", ["exp", "rational"])
def test_finite_at_the_extremes(phi):
    """alpha * size = 1e4 and 1e6, with coincident points (r = 0) in both clouds."""
    a, b = clouds(gap=0.0)
    b = PointCloud(np.vstack([b.points, a.points[:50]]), np.concatenate([b.weights, a.weights[:50]]))
    for alpha in (1e4, 1e6):
        r = SmoothHausdorff(alpha=alpha, phi=phi)(a, b)
        assert np.isfinite(r.value) and r.value > 0
        assert np.isfinite(r.grad_points).all() and np.isfinite(r.grad_weights).all()
    far = PointCloud(a.points + 1e3, a.weights)  # every term underflows without the shift
    assert np.isfinite(SmoothHausdorff(alpha=1e4, phi=phi)(far, b).value)


@pytest.mark.mpi
def test_distributed_clouds_give_the_serial_numbers():
    comm = MPI.COMM_WORLD
    a, b = clouds(400, 300)  # the same on every rank: the generator is seeded per module...
    a = PointCloud(comm.bcast(a.points), comm.bcast(a.weights))
    b = PointCloud(comm.bcast(b.points), comm.bcast(b.weights))
    H = SmoothHausdorff(alpha=40.0)
    serial = H(a, b, MPI.COMM_SELF)

    a_part, lo, hi = rank_share(a)
    b_part, _, _ = rank_share(b)
    dist = H(a_part, b_part, comm)
    assert dist.value == pytest.approx(serial.value, rel=1e-13)
    assert np.allclose(dist.grad_points, serial.grad_points[lo:hi], rtol=1e-11, atol=1e-15)
    assert np.allclose(dist.grad_weights, serial.grad_weights[lo:hi], rtol=1e-11, atol=1e-15)
    assert exact_hausdorff(a_part, b_part, comm) == pytest.approx(
        exact_hausdorff(a, b), rel=1e-15)


def test_the_pair_loop_is_written_once_and_its_variants_agree():
    """shape/pairs.py's template is the only pair loop of the package; its float64 gather,
    its scatter and its kept gather with the replay give one pair sum, each the other's
    transpose, against a sum written in numpy; a variant it has no arithmetic for is
    refused by name."""
    import re

    from shapegrowth.shape import pairs

    sources = sorted((ROOT / "shapegrowth" / "shape").glob("*.py"))
    # a pair sum's loop takes each pair's taper (S, -dS/du) of its exponent u
    loops = {p.name: len(re.findall(r"\bs, ds = \w+\(u, ", p.read_text())) for p in sources}
    assert {k: v for k, v in loops.items() if v} == {"pairs.py": 1}

    rng = np.random.default_rng(0)
    xs, ys, zs = (rng.random(37) for _ in range(3))
    w = rng.random(37) + 0.5
    q, base, a = (0.3, 0.4, 0.5), 0.05, 0.7
    taper = pairs.Taper.of(20.0, 6.0, 2.0)
    r = np.sqrt((q[0] - xs) ** 2 + (q[1] - ys) ** 2 + (q[2] - zs) ** 2)
    u = np.minimum(20.0 * (r - base), 100.0)
    t = np.clip((6.0 - u) / 2.0, 0.0, 1.0)
    S, dS = t * t * (3 - 2 * t), 6 * t * (1 - t) / 2.0
    e = np.exp(-u)
    none, acc = (np.zeros(0), np.zeros(0)), tuple(np.zeros(0) for _ in range(4))
    z, vx, vy, vz, p = pairs.pair_loop("float64", "exp", "sums")(
        *q, base, taper, 0.0, (xs, ys, zs), w, none, acc)
    assert z == pytest.approx(np.sum(w * e * S), rel=1e-12)
    assert p == pytest.approx(np.sum(w * e * dS), rel=1e-12)
    f = w * e * (S + dS) / r
    assert np.allclose([vx, vy, vz], [np.sum(f * (q[0] - xs)), np.sum(f * (q[1] - ys)),
                                      np.sum(f * (q[2] - zs))], rtol=1e-12, atol=0)
    scattered = tuple(np.zeros(37) for _ in range(4))
    pairs.pair_loop("float64", "exp", "scatter")(*q, base, taper, a, (xs, ys, zs), w, none,
                                                 scattered)
    assert np.allclose(scattered[3], a * e * S, rtol=1e-12, atol=0)
    assert np.allclose(scattered[0], a * e * (S + dS) / r * (q[0] - xs), rtol=1e-12, atol=0)
    kept = (np.zeros(37), np.zeros(37))
    assert pairs.pair_loop("float64", "exp", "sums_kept")(
        *q, base, taper, 0.0, (xs, ys, zs), w, kept, acc)[0] == pytest.approx(z, rel=1e-12)
    replayed = tuple(np.zeros(37) for _ in range(4))
    pairs.pair_loop("float64", "exp", "replay")(*q, base, taper, a, (xs, ys, zs), w, kept,
                                                replayed)
    for got, want in zip(replayed, scattered):
        assert np.allclose(got, want, rtol=1e-12, atol=0)
    with pytest.raises(ValueError, match="float32, rational"):
        pairs.pair_loop("float32", "rational", "sums")
