"""rho_H with float32 pair sums (``objective.hausdorff.precision``: float32, or auto where
the grid prunes): its exp, its distance from the float64 numbers, exact gradients of what
it computes, the debiased shape term, where auto uses it, and the same numbers under MPI."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import rank_share, taylor_in_points
from mpi4py import MPI

from shapegrowth.shape.divergence import ShapeDivergence
from shapegrowth.shape.hausdorff import PointCloud, SmoothHausdorff

RNG = np.random.default_rng(32)
pytestmark = pytest.mark.usefixtures("compiled_kernels32")


def beams(n=4000, m=3000, gap=0.01):
    """Two beam-like clouds (1 x 0.1 x 0.02), the second waved and shifted: the shapes of
    the bench's case, with a grid that prunes."""
    a = RNG.random((n, 3)) * [1.0, 0.1, 0.02]
    b = RNG.random((m, 3)) * [1.0, 0.1, 0.02]
    b[:, 2] += 0.05 * np.sin(2 * np.pi * b[:, 0]) + gap
    return (PointCloud(a, RNG.uniform(0.5, 1.5, n) / n),
            PointCloud(b, RNG.uniform(0.5, 1.5, m) / m))


def test_exp32_is_float32_accurate():
    """Degree 7 after range reduction: within a few float32 ulps of exp on [-80, 0]."""
    from shapegrowth.shape.kernels32 import exp32_array

    x = np.concatenate([-80.0 * RNG.random(100000), np.linspace(-80.0, 0.0, 20001),
                        [0.0, -0.0, -80.0]]).astype(np.float32)
    assert np.max(np.abs(exp32_array(x) / np.exp(x.astype(float)) - 1.0)) < 4e-7


@pytest.mark.parametrize("truncate", [False, True])
def test_within_a_millionth_of_float64(truncate):
    """rho_H and its gradients against the float64 sums (here ~1e-9 and ~1e-6; the bench's
    50k-DOF state: 3.6e-10 in S, 5e-6 of the largest gradient, docs/PERFORMANCE.md)."""
    a, b = beams()
    wide = SmoothHausdorff(alpha=200.0, truncate=truncate)(a, b)
    single = SmoothHausdorff(alpha=200.0, truncate=truncate, precision="float32")(a, b)
    assert single.truncated == wide.truncated == truncate
    assert single.value == pytest.approx(wide.value, rel=1e-7)
    assert single.value != wide.value  # the float32 path did run
    assert single.hausdorff == wide.hausdorff  # the nearest sources are searched in float64
    for s, w in [(single.grad_points, wide.grad_points),
                 (single.grad_weights, wide.grad_weights)]:
        assert np.abs(s - w).max() < 1e-5 * np.abs(w).max()


def test_taylor_in_float32():
    """What float32 computes is differentiated exactly: the rate holds for steps whose
    change of rho_H stands above float32's rounding (from 1e-2 down)."""
    a, b = beams(3000, 2500)
    H = SmoothHausdorff(alpha=200.0, gamma=3.0, truncate=True, precision="float32")
    dp = 0.005 * RNG.standard_normal((len(a.weights), 3))
    result = taylor_in_points(H, a, b, dp, eps0=1e-2)
    assert result.min_rate > 1.9, result.rates


@pytest.mark.parametrize("with_gradient", [False, True])
def test_one_sweep_gives_the_two_passes_sums(with_gradient):
    """soft_values_scatter32 (the values, and the source gradient from the pairs it kept)
    against soft_values32 and soft_source_gradient32 with the same coefficients."""
    from scipy.spatial import cKDTree

    from shapegrowth.shape import kernels32, sweep32
    from shapegrowth.shape.cellgrid import SourceGrid
    from shapegrowth.shape.pairs import Taper

    a, b = beams()
    alpha, beta, cut, width = 200.0, 2.0, 14.0, 2.0
    queries = b.points
    gmin = cKDTree(a.points).query(queries)[0]
    radius = gmin + cut / alpha
    grid = SourceGrid.build(a.points, a.weights, float(np.median(radius)), local32=True)
    top, total = grid.weights.max(), grid.weights.sum()
    w32 = (grid.weights / top).astype(np.float32)
    walk = (grid.cells, gmin, radius, Taper.of(alpha, cut, width, "float32"))
    sources = (grid.local32, grid.box32, w32)
    qscale = b.weights / b.weights.max()
    Z, V, P, acc = sweep32.soft_values_scatter32(
        queries, sources, *walk, with_gradient,
        sweep32.Coefficient(qscale, alpha, beta, float(np.log(top / total))), 4)
    Z2, V2, P2 = kernels32.soft_values32(queries, sources, *walk, with_gradient, 4)
    assert np.allclose(Z, Z2, rtol=1e-6, atol=0) and np.allclose(P, P2, rtol=1e-5, atol=0)
    assert np.abs(V - V2).max() <= 1e-5 * np.abs(V2).max()
    d = gmin - (np.log(Z2) + np.log(top / total)) / alpha
    coef = qscale * (alpha * d) ** (beta - 1.0) / Z2
    acc2 = coef.max() * kernels32.soft_source_gradient32(
        queries, sources[:2], *walk, (coef / coef.max()).astype(np.float32), 4)
    assert np.abs(acc - acc2).max() <= 1e-5 * np.abs(acc2).max()


def test_balls_over_many_cells_sum_as_float64():
    """Queries far from the sources meet hundreds of cells (more slabs than the span arrays
    first hold, so they grow): the float32 sweeps against the float64 loops of kernels.py."""
    from scipy.spatial import cKDTree

    from shapegrowth.shape import kernels, kernels32, sweep32
    from shapegrowth.shape.cellgrid import SourceGrid
    from shapegrowth.shape.pairs import Taper

    a, b = beams()
    queries = np.concatenate([b.points[:40], b.points[:5] + [0.0, 0.0, 0.3]])
    alpha, cut, width = 200.0, 14.0, 2.0
    gmin = cKDTree(a.points).query(queries)[0]
    radius = gmin + cut / alpha
    grid = SourceGrid.build(a.points, a.weights, 0.01, local32=True)
    Z, V, P = kernels.soft_values(queries, (grid.xyz, grid.weights), grid.cells, gmin, radius,
                                  Taper.of(alpha, cut, width), False, True)
    w32 = grid.weights.astype(np.float32)
    walk = (grid.cells, gmin, radius, Taper.of(alpha, cut, width, "float32"))
    Z1, V1, P1 = kernels32.soft_values32(queries, (grid.local32, grid.box32, w32), *walk, True,
                                         4)
    ones = sweep32.Coefficient(np.ones(len(queries)), alpha, 2.0, 0.0)
    Z2, V2, P2, _ = sweep32.soft_values_scatter32(queries, (grid.local32, grid.box32, w32),
                                                     *walk, True, ones, 4)
    for z, v in ((Z1, V1), (Z2, V2)):
        assert np.allclose(z, Z, rtol=1e-5, atol=0)
        assert np.abs(v - V).max() <= 1e-5 * np.abs(V).max()


def test_cell_boxes_are_their_sources_bounds():
    """Each cell's box (the y and z bounds that kernels32._slab trims by) holds its sources'
    offsets and is attained by them; the x offsets are sorted within the cell."""
    from shapegrowth.shape.cellgrid import SourceGrid

    a, _ = beams()
    grid = SourceGrid.build(a.points, a.weights, 0.05, local32=True)
    assert grid.box32 is not None and grid.local32 is not None
    filled = 0
    for c in range(grid.ncells):
        j0, j1 = grid.start[c], grid.start[c + 1]
        if j1 == j0:
            continue
        filled += 1
        y, z = grid.local32[1, j0:j1], grid.local32[2, j0:j1]
        assert list(grid.box32[c]) == [y.min(), y.max(), z.min(), z.max()]
        assert np.all(np.diff(grid.local32[0, j0:j1]) >= 0)
    assert filled > 10


def test_dealt_queries_keep_their_blocks_and_span_the_cloud():
    """locality_order with parts: a permutation of the queries, blocks of QUERY_BLOCK
    neighbours kept whole, and each part's range reaching from one end of the cloud to the
    other (a static split among threads gives each thread its share of both)."""
    from shapegrowth.shape import cellgrid
    from shapegrowth.shape.cellgrid import SourceGrid

    a, b = beams()
    grid = SourceGrid.build(a.points, a.weights, 0.05, local32=True)
    plain = grid.locality_order(b.points)
    dealt = grid.locality_order(b.points, parts=4)
    assert sorted(dealt) == list(range(len(b.points)))
    block = cellgrid.QUERY_BLOCK
    assert np.array_equal(dealt[:block], plain[:block])
    assert np.array_equal(dealt[block:2 * block], plain[4 * block:5 * block])
    rank = np.empty(len(plain), dtype=int)
    rank[plain] = np.arange(len(plain))
    for part in np.array_split(rank[dealt], 4):
        assert part.min() < 0.1 * len(plain) and part.max() > 0.9 * len(plain)


def test_taylor_in_float32_below_beta_one():
    """beta < 1 keeps the two passes (the one sweep's float32 coefficients need beta >= 1):
    its gradient is exact too."""
    a, b = beams(3000, 2500)
    H = SmoothHausdorff(alpha=200.0, beta=0.5, truncate=True, precision="float32")
    dp = 0.005 * RNG.standard_normal((len(a.weights), 3))
    # from 2e-2: at 6e-4 the residual (3e-10) met float32's rounding (rate 1.84)
    result = taylor_in_points(H, a, b, dp, eps0=2e-2)
    assert result.min_rate > 1.9, result.rates


def test_debiased_term_in_float32():
    """S = rho_H(B, T) - (rho_H(B, B) + rho_H(T, T)) / 2, both self terms in float32 too."""
    a, b = beams()
    wide = ShapeDivergence(SmoothHausdorff(alpha=200.0))(a, b)
    single = ShapeDivergence(SmoothHausdorff(alpha=200.0, precision="float32"))(a, b)
    assert single.value == pytest.approx(wide.value, rel=1e-5)
    assert single.body_self == pytest.approx(wide.body_self, rel=1e-6)
    assert np.abs(single.grad_points - wide.grad_points).max() < 2e-5 * np.abs(
        wide.grad_points).max()


def test_float32_needs_the_exponential_and_a_finite_cutoff():
    with pytest.raises(ValueError, match="phi 'exp'"):
        SmoothHausdorff(phi="rational", precision="float32")
    with pytest.raises(ValueError, match="cutoff of at most 60"):
        SmoothHausdorff(cutoff=np.inf, precision="float32")


def test_auto_is_float32_where_the_grid_prunes():
    """'auto' (the config's default): float32 for clouds the grid prunes, float64 for the
    small ones it sums whole and wherever phi or the cutoff does not allow float32."""
    big, target = beams()
    small, small_target = beams(400, 300)

    def value(cloud, other, **kw):
        return SmoothHausdorff(alpha=200.0, **kw)(cloud, other).value

    assert value(big, target, precision="auto") == value(big, target, precision="float32")
    assert value(big, target, precision="auto") != value(big, target)
    assert value(small, small_target, precision="auto") == value(small, small_target)
    assert value(big, target, precision="auto", phi="rational") == value(big, target,
                                                                       phi="rational")
    assert value(big, target, precision="auto", cutoff=80.0) == value(big, target, cutoff=80.0)


@pytest.mark.mpi
def test_distributed_float32_gives_the_serial_numbers():
    """The same numbers to float32's rounding: each rank sizes the grid from a sample of its
    own queries, so the cells, the float32 offsets in them and the source gradients' float32
    partial sums differ from the serial run's (measured 5e-10 in the value)."""
    comm = MPI.COMM_WORLD
    a, b = beams()
    a = PointCloud(comm.bcast(a.points), comm.bcast(a.weights))
    b = PointCloud(comm.bcast(b.points), comm.bcast(b.weights))
    H = SmoothHausdorff(alpha=200.0, precision="float32")
    serial = H(a, b, MPI.COMM_SELF)
    a_part, lo, hi = rank_share(a)
    b_part, _, _ = rank_share(b)
    dist = H(a_part, b_part, comm)
    assert dist.value == pytest.approx(serial.value, rel=1e-8)
    scale = np.abs(serial.grad_points).max()
    assert np.abs(dist.grad_points - serial.grad_points[lo:hi]).max() < 1e-5 * scale
