"""The smooth Hausdorff distance rho_H of (2.9) between weighted point clouds, and the
exact (non-smooth) Hausdorff distance.

Both bodies are weighted point clouds: the deformed body is the quadrature points
Phi(X_q) with weights J w_q, the target the points Phi_d(X_q) with push-forward
weights (see targets.py).  With phi^alpha(r) = exp(-alpha g(r)),

    d_B(q)   = phi^-1( (sum_b w_b phi^alpha(|q - b|) / W_B)^(1/alpha) )   (soft distance)
    D1       = ( sum_t v_t d_B(t)^beta / W_T )^(1/beta)                  (target -> body)
    D2       = ( sum_b w_b d_T(b)^beta / W_B )^(1/beta)                  (body -> target)
    rho_H    = ( D1^gamma + D2^gamma )^(1/gamma).

alpha has the units of 1/length: ``alpha * size`` (size = the target's largest
extent) sets how sharp the soft minimum is.  The soft distance of a point is
never below its true distance and exceeds it by about (dim/alpha) log(alpha * size)
for a body of dimension dim, so rho_H(A, A) > 0 (the bias, measured in the tests)
and rho_H -> the Hausdorff distance like log(alpha)/alpha.

Under MPI each rank holds its own points; the clouds are gathered, each rank
sums over its own points, and the sums are reduced.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from mpi4py import MPI
from scipy.spatial import cKDTree

from . import cellgrid, kernels, kernels32, pairs, sweep32


def _kdtree_workers() -> int:
    """All cores for the nearest-neighbour queries in serial; one per rank under MPI."""
    return -1 if MPI.COMM_WORLD.size == 1 else 1


@dataclass
class PointCloud:
    """Points (n, dim) with positive weights (n,), the part owned by this rank.

    A cloud is treated as immutable: its gathered arrays, their order by position, the
    grid of its nearest-source search and its KD-tree are built once and kept, so a target
    that is evaluated every iteration pays for them once."""

    points: np.ndarray
    weights: np.ndarray
    _gathered: tuple | None = field(default=None, init=False, repr=False, compare=False)
    _tree: cKDTree | None = field(default=None, init=False, repr=False, compare=False)
    _lexical: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)
    _search: cellgrid.SourceGrid | None = field(default=None, init=False, repr=False,
                                                compare=False)

    def gathered(self, comm: MPI.Comm) -> tuple[np.ndarray, np.ndarray, int]:
        """All ranks' points and weights, and this rank's offset in them."""
        if self._gathered is None or self._gathered[0] != comm.py2f():
            pts = comm.allgather(np.ascontiguousarray(self.points, dtype=np.float64))
            wts = comm.allgather(np.ascontiguousarray(self.weights, dtype=np.float64))
            offset = sum(len(p) for p in pts[:comm.rank])
            self._gathered = (comm.py2f(), cellgrid.as3(np.concatenate(pts)),
                              np.concatenate(wts), offset)
            self._tree = self._lexical = self._search = None
        return self._gathered[1:]

    def lexical(self, comm: MPI.Comm) -> np.ndarray:
        """All ranks' points in their order by position (cellgrid.lexical_order)."""
        points = self.gathered(comm)[0]
        if self._lexical is None:
            self._lexical = cellgrid.lexical_order(points)
        return self._lexical

    def search_grid(self, comm: MPI.Comm) -> cellgrid.SourceGrid:
        """The grid that the nearest-source search walks, over all ranks' points."""
        points, weights, _ = self.gathered(comm)
        if self._search is None:
            self._search = cellgrid.SourceGrid.build(points, weights,
                                                     cellgrid.search_cell(points),
                                                     lexical=self.lexical(comm))
        return self._search

    def tree(self, comm: MPI.Comm) -> cKDTree:
        """KD-tree of all ranks' points."""
        points = self.gathered(comm)[0]
        if self._tree is None:
            self._tree = cKDTree(points)
        return self._tree

    def extent(self, comm: MPI.Comm = MPI.COMM_SELF, revolved: bool = False) -> float:
        """Largest extent of the cloud along a coordinate axis; ``revolved``: the points are
        (R, Z) of a body of revolution about Z (R >= 0), and the extent is the revolved
        body's, max(2 max R, Z's extent), the same as a 3D cloud of that body would give."""
        pts = self.points
        lo, hi = cellgrid.bounding_box(pts)
        if not len(pts):
            lo, hi = np.full(pts.shape[1], np.inf), np.full(pts.shape[1], -np.inf)
        comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
        comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
        if revolved:  # across the axis: the diameter
            radius = max(abs(lo[0]), abs(hi[0]))
            lo[0], hi[0] = -radius, radius
        return float((hi - lo).max())


@dataclass
class _Direction:
    """One of the two directed terms of (2.9) and what its gradient needs."""

    mean: float  # D1 or D2
    d: np.ndarray  # soft distances of this rank's queries
    mu: np.ndarray  # dd/ds
    Z: np.ndarray
    V: np.ndarray  # ds/dq Z, the shift's part included
    P: np.ndarray  # -ds/dgmin Z: the taper's share
    dg: np.ndarray  # dgmin/dq (n, 3): g'(r) (q - x_n) / r of the nearest source x_n
    nearest: np.ndarray  # the nearest source's position in the grid's sorted order
    gmin: np.ndarray
    radius: np.ndarray
    grid: cellgrid.SourceGrid
    order: np.ndarray  # the queries in the order the sums' sweeps take them
    q_total: float  # total weight of the queries (all ranks)
    s_total: float  # total weight of the sources
    farthest: float  # largest nearest-source distance of a query (all ranks)
    # the source gradient's pair sums (grid order, as soft_source_gradient's), where the
    # values' sweep made them (sweep32.soft_values_scatter32)
    scattered: np.ndarray | None = None


@dataclass
class HausdorffResult:
    value: float
    d_target_to_body: float  # D1
    d_body_to_target: float  # D2
    hausdorff: float  # the exact (symmetric) Hausdorff distance of the two clouds
    grad_points: np.ndarray | None = None  # d rho / d body points (own)
    grad_weights: np.ndarray | None = None  # d rho / d body weights (own)
    truncated: bool = False


PRECISIONS = ("float64", "float32", "auto")


@dataclass(frozen=True)
class SmoothHausdorff:
    """rho_H of (2.9); ``phi`` is 'exp' (exp(-t)) or 'rational' (1/(1+t))."""

    alpha: float = 100.0
    beta: float = 2.0
    gamma: float = 2.0
    phi: str = "exp"
    truncate: bool | None = None  # None: use the cell grid where it prunes
    cutoff: float = kernels.CUTOFF  # pairs beyond exp(-cutoff) of the nearest are dropped
    taper: float = kernels.TAPER  # ... smoothly over the last ``taper`` e-folds before it
    # each pair's arithmetic: "float64", "float32" (kernels32.py), or "auto": float32 where
    # the grid prunes (large clouds, where the pair sums are the cost) and phi, cutoff allow
    precision: str = "float64"

    def __post_init__(self) -> None:
        if self.precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {PRECISIONS}, not {self.precision!r}")
        if self.precision == "float32" and not self._float32_allowed:
            raise ValueError("precision 'float32' needs phi 'exp' and a cutoff of at most 60")

    @property
    def _float32_allowed(self) -> bool:
        return not self.rational and self.cutoff <= 60.0

    @property
    def rational(self) -> bool:
        return self.phi == "rational"

    def _g(self, r: np.ndarray) -> np.ndarray:
        return np.log1p(r) if self.rational else r

    def _taper(self, precision: str) -> pairs.Taper:
        """alpha, the cutoff and the taper's width as the pair loops of ``precision`` take
        them; no taper for an infinite cutoff."""
        if not np.isfinite(self.cutoff):
            return pairs.Taper.of(self.alpha, 1e300, 1.0, precision)
        return pairs.Taper.of(self.alpha, float(self.cutoff),
                              float(min(self.taper, self.cutoff)), precision)

    def _cutoff_radius(self, gmin: np.ndarray) -> np.ndarray:
        reach = gmin + self.cutoff / self.alpha
        return np.expm1(reach) if self.rational else reach

    def _distance(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(d, mu) from the soft value s: d = s or exp(s) - 1, mu = dd/ds."""
        if self.rational:
            e = np.exp(s)
            return e - 1.0, e
        return s, np.ones_like(s)

    def _grid(self, sources, weights, radius, lexical) -> cellgrid.SourceGrid:
        """The sums' grid; with float32 offsets (``local32``) where the pairs run in float32."""
        use = self.truncate
        cell = cellgrid.auto_cell(sources, radius) if use is None else (
            float(np.median(radius)) if use else None)
        single = self.precision == "float32" or (
            self.precision == "auto" and self._float32_allowed and cell is not None)
        if single and use is None and cell is not None:  # float32 trims cells to slabs
            cell = cellgrid.auto_cell(sources, radius, cellgrid.SLAB_CELL)
        return cellgrid.SourceGrid.build(sources, weights, cell, local32=single,
                                         lexical=lexical)

    def _mean_distance(self, queries, q_weights, cloud: PointCloud, comm,
                       query_gradient: bool = True, itself: int | None = None,
                       scatter: bool = False) -> _Direction:
        """Soft distances of this rank's ``queries`` to all ranks' points of ``cloud`` (the
        sources) and their beta-mean over all ranks' queries (D1 or D2 of (2.9)); V only
        with ``query_gradient``.

        The exact nearest distances (the shift g_min, and the exact Hausdorff distance for
        free) come from a grid of fine cells (cellgrid.search_cell), the sums from a grid sized
        by the cutoff radii they give.  ``itself``: the queries are the sources from this
        position on (a cloud with itself), so each query's nearest source is itself, at
        distance 0, and no search is made.  ``scatter``: the sources' gradient will be
        wanted; in float32 (beta >= 1) the values' sweep makes its pair sums too."""
        kernels.one_thread_per_rank()
        sources, s_weights, _ = cloud.gathered(comm)
        nearest = np.zeros(len(queries))
        if itself is None:
            search = cloud.search_grid(comm)
            lookup = search.locality_order(queries, _chunks(len(queries)))
            source_of = np.empty(len(queries), dtype=np.int64)
            nearest[lookup], found = cellgrid.nearest_source(
                np.ascontiguousarray(queries[lookup]), search.xyz, search.origin, search.cell,
                search.shape, search.start)
            source_of[lookup] = search.order[found]
        else:
            source_of = itself + np.arange(len(queries))
        gmin = self._g(nearest)
        radius = self._cutoff_radius(gmin)
        grid = self._grid(sources, s_weights, radius, cloud.lexical(comm))
        position = np.empty(len(sources), dtype=np.int64)
        position[grid.order] = np.arange(len(sources))
        index = position[source_of]  # each query's nearest source in the sums' grid's order
        order = grid.locality_order(queries, _chunks(len(queries)))
        ordered = np.ascontiguousarray(queries[order])
        Z, V, P = np.empty(len(queries)), np.empty((len(queries), 3)), np.empty(len(queries))
        total = float(s_weights.sum())
        scattered = None
        fused = scatter and grid.local32 is not None and self.beta >= 1.0
        if fused:
            top = float(grid.weights.max(initial=0.0)) or 1.0
            q_top = float(q_weights.max(initial=0.0)) or 1.0
            coef = sweep32.Coefficient(q_weights[order] / q_top, float(self.alpha),
                                       float(self.beta), float(np.log(top / total)))
            Z[order], V[order], P[order], scattered = sweep32.soft_values_scatter32(
                ordered, (grid.local32, grid.box32, (grid.weights / top).astype(np.float32)),
                grid.cells, gmin[order], radius[order], self._taper("float32"),
                query_gradient, coef, _chunks(len(queries)))
            Z *= top
            V *= top
            P *= top
        elif grid.local32 is not None:
            top = float(grid.weights.max(initial=0.0)) or 1.0  # weights as fractions of it
            sums = kernels32.soft_values32(
                ordered, (grid.local32, grid.box32, (grid.weights / top).astype(np.float32)),
                grid.cells, gmin[order], radius[order], self._taper("float32"),
                query_gradient, _chunks(len(queries)))
            Z[order], V[order], P[order] = (top * part for part in sums)
        else:
            Z[order], V[order], P[order] = kernels.soft_values(
                ordered, (grid.xyz, grid.weights), grid.cells, gmin[order], radius[order],
                self._taper("float64"), self.rational, query_gradient)
        # the shift gmin = g(|q - x_n|) moves the taper: ds/dgmin = -P / Z, dgmin/dq = dg
        offset = queries - grid.xyz[:, index].T
        slope = 1.0 / (1.0 + nearest) if self.rational else np.ones_like(nearest)
        dg = (slope / np.maximum(nearest, 1e-300))[:, None] * offset
        if query_gradient:
            V -= P[:, None] * dg
        d, mu = self._distance(gmin - np.log(Z / total) / self.alpha)
        q_total = comm.allreduce(float(q_weights.sum()), MPI.SUM)
        A = comm.allreduce(float(np.sum(q_weights * d**self.beta)), MPI.SUM)
        farthest = comm.allreduce(float(np.max(nearest)) if nearest.size else 0.0, MPI.MAX)
        D = (A / q_total) ** (1.0 / self.beta)
        if scattered is not None:  # the kernel's coefficient times what is common to all
            scattered *= (D ** (1 - self.beta) * q_top * self.alpha ** (1 - self.beta)
                          / (q_total * top))
        return _Direction(D, d, mu, Z, V, P, dg, index, gmin, radius, grid, order, q_total,
                          total, farthest, scattered)

    def soft_distance(self, points: np.ndarray, cloud: PointCloud) -> np.ndarray:
        """The soft distance d_cloud(x) of (2.9) for each of ``points`` (serial)."""
        queries = cellgrid.as3(np.atleast_2d(points))
        return self._mean_distance(queries, np.ones(len(queries)), cloud, MPI.COMM_SELF).d

    def __call__(self, body: PointCloud, target: PointCloud, comm: MPI.Comm = MPI.COMM_SELF,
                 gradient: bool = True) -> HausdorffResult:
        gamma = self.gamma
        b_off = body.gathered(comm)[2]
        b_own, wb_own = cellgrid.as3(body.points), np.asarray(body.weights, dtype=float)
        t_own, wt_own = cellgrid.as3(target.points), np.asarray(target.weights, dtype=float)

        # target -> body: the target points do not move, only the sources' gradient is needed
        d1 = self._mean_distance(t_own, wt_own, body, comm, query_gradient=False,
                                 scatter=gradient)
        d2 = self._mean_distance(b_own, wb_own, target, comm)  # body -> target
        D1, D2 = d1.mean, d2.mean
        rho = (D1**gamma + D2**gamma) ** (1.0 / gamma)
        truncated = d1.grid.ncells > 1 or d2.grid.ncells > 1
        result = HausdorffResult(rho, D1, D2, max(d1.farthest, d2.farthest),
                                 truncated=truncated)
        if not gradient:
            return result
        dr_dD1 = rho ** (1 - gamma) * D1 ** (gamma - 1)
        dr_dD2 = rho ** (1 - gamma) * D2 ** (gamma - 1)
        q_pts, q_w = self._query_part(d2, wb_own)  # D2 through the body points as queries
        s_pts, s_w = self._source_part(d1, t_own, wt_own, wb_own, b_off, comm)  # D1: sources
        dim = body.points.shape[1]
        result.grad_points = (dr_dD2 * q_pts + dr_dD1 * s_pts)[:, :dim]
        result.grad_weights = dr_dD2 * q_w + dr_dD1 * s_w
        return result

    def self_distance(self, cloud: PointCloud, comm: MPI.Comm = MPI.COMM_SELF,
                      gradient: bool = True) -> HausdorffResult:
        """rho_H(A, A) of a cloud with itself, and its gradient with respect to the cloud.

        Both directed terms are the same mean D of the soft distances of A's points to A,
        so rho_H(A, A) = 2^(1/gamma) D and one pair sum serves both; a point moves as a
        query and as a source at once, so its gradient is the sum of the two parts (the
        pair of a point with itself has r = 0 in both roles and contributes nothing)."""
        offset = cloud.gathered(comm)[2]
        own, w_own = cellgrid.as3(cloud.points), np.asarray(cloud.weights, dtype=float)
        d = self._mean_distance(own, w_own, cloud, comm, query_gradient=gradient,
                                itself=offset, scatter=gradient)
        scale = 2.0 ** (1.0 / self.gamma)
        result = HausdorffResult(scale * d.mean, d.mean, d.mean, 0.0,
                                 truncated=d.grid.ncells > 1)
        if gradient:
            q_pts, q_w = self._query_part(d, w_own)
            s_pts, s_w = self._source_part(d, own, w_own, w_own, offset, comm)
            result.grad_points = scale * (q_pts + s_pts)[:, :cloud.points.shape[1]]
            result.grad_weights = scale * (q_w + s_w)
        return result

    def _query_part(self, d: _Direction, q_weights: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
        """dD/d(own query points) (n, 3) and dD/d(own query weights) of one directed mean."""
        beta, D, W = self.beta, d.mean, d.q_total
        dD_dA = D ** (1 - beta) / (beta * W)
        tiny = np.finfo(float).tiny
        pts = (dD_dA * beta) * (q_weights * np.maximum(d.d, tiny) ** (beta - 1)
                                * d.mu / d.Z)[:, None] * d.V
        return pts, dD_dA * d.d**beta - D / (beta * W)

    def _source_part(self, d: _Direction, queries: np.ndarray, q_weights: np.ndarray,
                     s_weights: np.ndarray, s_offset: int, comm: MPI.Comm
                     ) -> tuple[np.ndarray, np.ndarray]:
        """dD/d(own source points) (n, 3) and dD/d(own source weights) of one directed mean:
        through every soft distance of a query, summed over all ranks' queries."""
        beta, D = self.beta, d.mean
        tiny = np.finfo(float).tiny
        c = D ** (1 - beta) * q_weights * np.maximum(d.d, tiny) ** (beta - 1) / d.q_total
        coef = c * d.mu / d.Z
        grid = d.grid
        acc = d.scattered if d.scattered is not None else self._scatter(d, queries, coef)
        acc[:, :3] *= -grid.weights[:, None]
        # the shift: each query's nearest source x_n moves its gmin, dgmin/dx_n = -dg
        shift = coef * d.P
        for k in range(3):  # np.add.at took 10 ms at the bench's case
            acc[:, k] += np.bincount(d.nearest, shift * d.dg[:, k], minlength=len(acc))
        full = np.empty_like(acc)
        full[grid.order] = acc  # back to the gathered order
        comm.Allreduce(MPI.IN_PLACE, full, op=MPI.SUM)
        sum_coef = comm.allreduce(float(np.sum(c * d.mu)), MPI.SUM)
        mine = full[s_offset:s_offset + len(s_weights)]
        return mine[:, :3], -(1.0 / self.alpha) * (mine[:, 3] - sum_coef / d.s_total)

    def _scatter(self, d: _Direction, queries: np.ndarray, coef: np.ndarray) -> np.ndarray:
        """The source gradient's pair sums in a pass of their own (soft_source_gradient)."""
        nchunks = _chunks(len(queries))
        grid, order = d.grid, d.order
        ordered = np.ascontiguousarray(queries[order])
        if grid.local32 is not None:
            top = float(np.abs(coef).max(initial=0.0)) or 1.0  # coefficients as fractions
            return top * kernels32.soft_source_gradient32(
                ordered, (grid.local32, grid.box32), grid.cells, d.gmin[order],
                d.radius[order], self._taper("float32"),
                (coef[order] / top).astype(np.float32), nchunks)
        return kernels.soft_source_gradient(ordered, grid.xyz, grid.cells, d.gmin[order],
                                            d.radius[order], self._taper("float64"),
                                            self.rational, coef[order], nchunks)


def _chunks(n: int) -> int:
    """Blocks of queries of the pair sweeps (each with its buffers of the source sums),
    and the parts the queries are dealt to (SourceGrid.locality_order)."""
    return max(1, min(8, n))


def exact_hausdorff(a: PointCloud, b: PointCloud, comm: MPI.Comm = MPI.COMM_SELF) -> float:
    """Symmetric Hausdorff distance between two point sets (KD-tree)."""
    a_tree, b_tree = a.tree(comm), b.tree(comm)
    d_ab = b_tree.query(cellgrid.as3(a.points), k=1, workers=_kdtree_workers())[0]
    d_ba = a_tree.query(cellgrid.as3(b.points), k=1, workers=_kdtree_workers())[0]
    local = max(d_ab.max(initial=0.0), d_ba.max(initial=0.0))
    return comm.allreduce(float(local), MPI.MAX)

