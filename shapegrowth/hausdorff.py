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

from . import cellgrid, kernels


def _kdtree_workers() -> int:
    """All cores for the nearest-neighbour queries in serial; one per rank under MPI."""
    return -1 if MPI.COMM_WORLD.size == 1 else 1


@dataclass
class PointCloud:
    """Points (n, dim) with positive weights (n,), the part owned by this rank.

    A cloud is treated as immutable: its gathered arrays and KD-tree are built once
    and kept, so a target that is evaluated every iteration pays for them once."""

    points: np.ndarray
    weights: np.ndarray
    _gathered: tuple | None = field(default=None, init=False, repr=False, compare=False)
    _tree: cKDTree | None = field(default=None, init=False, repr=False, compare=False)

    def gathered(self, comm: MPI.Comm) -> tuple[np.ndarray, np.ndarray, int]:
        """All ranks' points and weights, and this rank's offset in them."""
        if self._gathered is None or self._gathered[0] != comm.py2f():
            pts = comm.allgather(np.ascontiguousarray(self.points, dtype=np.float64))
            wts = comm.allgather(np.ascontiguousarray(self.weights, dtype=np.float64))
            offset = sum(len(p) for p in pts[:comm.rank])
            self._gathered = (comm.py2f(), cellgrid.as3(np.concatenate(pts)),
                              np.concatenate(wts), offset)
            self._tree = None
        return self._gathered[1:]

    def tree(self, comm: MPI.Comm) -> cKDTree:
        """KD-tree of all ranks' points."""
        points = self.gathered(comm)[0]
        if self._tree is None:
            self._tree = cKDTree(points)
        return self._tree

    def extent(self, comm: MPI.Comm = MPI.COMM_SELF) -> float:
        """Largest extent of the cloud along a coordinate axis."""
        pts = self.points
        lo = pts.min(axis=0) if len(pts) else np.full(pts.shape[1], np.inf)
        hi = pts.max(axis=0) if len(pts) else np.full(pts.shape[1], -np.inf)
        comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
        comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
        return float((hi - lo).max())


@dataclass
class _Direction:
    """One of the two directed terms of (2.9) and what its gradient needs."""

    mean: float  # D1 or D2
    d: np.ndarray  # soft distances of this rank's queries
    mu: np.ndarray  # dd/ds
    Z: np.ndarray
    V: np.ndarray
    gmin: np.ndarray
    radius: np.ndarray
    grid: cellgrid.SourceGrid
    q_total: float  # total weight of the queries (all ranks)
    farthest: float  # largest nearest-source distance of a query (all ranks)


@dataclass
class HausdorffResult:
    value: float
    d_target_to_body: float  # D1
    d_body_to_target: float  # D2
    hausdorff: float  # the exact (symmetric) Hausdorff distance of the two clouds
    grad_points: np.ndarray | None = None  # d rho / d body points (own)
    grad_weights: np.ndarray | None = None  # d rho / d body weights (own)
    truncated: bool = False


@dataclass(frozen=True)
class SmoothHausdorff:
    """rho_H of (2.9); ``phi`` is 'exp' (exp(-t)) or 'rational' (1/(1+t))."""

    alpha: float = 100.0
    beta: float = 2.0
    gamma: float = 2.0
    phi: str = "exp"
    truncate: bool | None = None  # None: use the cell grid where it prunes
    cutoff: float = kernels.CUTOFF  # pairs beyond exp(-cutoff) of the nearest are dropped

    @property
    def rational(self) -> bool:
        return self.phi == "rational"

    def _g(self, r: np.ndarray) -> np.ndarray:
        return np.log1p(r) if self.rational else r

    def _cutoff_radius(self, gmin: np.ndarray) -> np.ndarray:
        reach = gmin + self.cutoff / self.alpha
        return np.expm1(reach) if self.rational else reach

    def _distance(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(d, mu) from the soft value s: d = s or exp(s) - 1, mu = dd/ds."""
        if self.rational:
            e = np.exp(s)
            return e - 1.0, e
        return s, np.ones_like(s)

    def _grid(self, sources, weights, radius) -> cellgrid.SourceGrid:
        use = self.truncate
        cell = cellgrid.auto_cell(sources, radius) if use is None else (
            float(np.median(radius)) if use else None)
        return cellgrid.SourceGrid.build(sources, weights, cell)

    def _mean_distance(self, queries, q_weights, sources, s_weights, comm,
                       query_gradient: bool = True) -> "_Direction":
        """Soft distances of this rank's ``queries`` to all ``sources`` and their beta-mean
        over all ranks' queries (D1 or D2 of (2.9)); V only with ``query_gradient``.

        The grid is sized from a sample of nearest distances; the exact nearest distances
        (the shift g_min, and the exact Hausdorff distance for free) come from the grid."""
        estimate = self._cutoff_radius(self._g(cellgrid.sample_nearest(queries, sources)))
        grid = self._grid(sources, s_weights, estimate)
        order = grid.locality_order(queries)
        ordered = np.ascontiguousarray(queries[order])
        nearest = np.empty(len(queries))
        nearest[order] = cellgrid.nearest_distance(ordered, grid.xyz, grid.origin, grid.cell,
                                                   grid.shape, grid.start)
        gmin = self._g(nearest)
        radius = self._cutoff_radius(gmin)
        Z, V = np.empty(len(queries)), np.empty((len(queries), 3))
        Z[order], V[order] = kernels.soft_values(
            ordered, grid.xyz, grid.weights, grid.origin, grid.cell,
            grid.shape, grid.start, gmin[order], radius[order], self.alpha, self.rational,
            query_gradient)
        total = float(s_weights.sum())
        d, mu = self._distance(gmin - np.log(Z / total) / self.alpha)
        q_total = comm.allreduce(float(q_weights.sum()), MPI.SUM)
        A = comm.allreduce(float(np.sum(q_weights * d**self.beta)), MPI.SUM)
        farthest = comm.allreduce(float(nearest.max(initial=0.0)), MPI.MAX)
        return _Direction((A / q_total) ** (1.0 / self.beta), d, mu, Z, V, gmin, radius, grid,
                          q_total, farthest)

    def soft_distance(self, points: np.ndarray, cloud: PointCloud) -> np.ndarray:
        """The soft distance d_cloud(x) of (2.9) for each of ``points`` (serial)."""
        queries = cellgrid.as3(np.atleast_2d(points))
        sources = cellgrid.as3(cloud.points)
        weights = np.asarray(cloud.weights, dtype=float)
        return self._mean_distance(queries, np.ones(len(queries)), sources, weights,
                                   MPI.COMM_SELF).d

    def __call__(self, body: PointCloud, target: PointCloud, comm: MPI.Comm = MPI.COMM_SELF,
                 gradient: bool = True) -> HausdorffResult:
        alpha, beta, gamma = self.alpha, self.beta, self.gamma
        b_all, wb_all, b_off = body.gathered(comm)
        t_all, wt_all, _ = target.gathered(comm)
        b_own, wb_own = cellgrid.as3(body.points), np.asarray(body.weights, dtype=float)
        t_own, wt_own = cellgrid.as3(target.points), np.asarray(target.weights, dtype=float)

        # target -> body: the target points do not move, only the sources' gradient is needed
        d1 = self._mean_distance(t_own, wt_own, b_all, wb_all, comm, query_gradient=False)
        d2 = self._mean_distance(b_own, wb_own, t_all, wt_all, comm)  # body -> target
        D1, D2, WB, WT = d1.mean, d2.mean, d2.q_total, d1.q_total
        grid_b, grid_t = d1.grid, d2.grid
        d_t, mu_t, Z_t, gmin_t, rad_t = d1.d, d1.mu, d1.Z, d1.gmin, d1.radius
        d_b, mu_b, Z_b, V_b = d2.d, d2.mu, d2.Z, d2.V

        rho = (D1**gamma + D2**gamma) ** (1.0 / gamma)
        truncated = grid_b.ncells > 1 or grid_t.ncells > 1
        result = HausdorffResult(rho, D1, D2, max(d1.farthest, d2.farthest),
                                 truncated=truncated)
        if not gradient:
            return result

        dr_dD1 = rho ** (1 - gamma) * D1 ** (gamma - 1)
        dr_dD2 = rho ** (1 - gamma) * D2 ** (gamma - 1)
        tiny = np.finfo(float).tiny

        # D2's gradient: own body points directly
        dD2_dA2 = D2 ** (1 - beta) / (beta * WB)
        grad_pts = (dr_dD2 * dD2_dA2 * beta) * (wb_own * np.maximum(d_b, tiny) ** (beta - 1)
                                                * mu_b / Z_b)[:, None] * V_b
        grad_w = dr_dD2 * (dD2_dA2 * d_b**beta - D2 / (beta * WB))

        # D1's gradient: through every soft distance d_B(t), summed over the target points
        c_t = D1 ** (1 - beta) * wt_own * np.maximum(d_t, tiny) ** (beta - 1) / WT
        coef = c_t * mu_t / Z_t
        nchunks = max(1, min(8, len(t_own)))
        order = grid_b.locality_order(t_own)
        acc = kernels.soft_source_gradient(np.ascontiguousarray(t_own[order]), grid_b.xyz,
                                           grid_b.origin, grid_b.cell, grid_b.shape,
                                           grid_b.start, gmin_t[order], rad_t[order], alpha,
                                           self.rational, coef[order], nchunks)
        full = np.empty_like(acc)
        full[grid_b.order] = acc  # back to the gathered order
        comm.Allreduce(MPI.IN_PLACE, full, op=MPI.SUM)
        sum_coef = comm.allreduce(float(np.sum(c_t * mu_t)), MPI.SUM)
        mine = full[b_off:b_off + len(b_own)]
        dim = body.points.shape[1]
        grad_pts += dr_dD1 * (-wb_own[:, None] * mine[:, :3])
        grad_w += dr_dD1 * (-(1.0 / alpha) * (mine[:, 3] - sum_coef / WB))
        result.grad_points = grad_pts[:, :dim]
        result.grad_weights = grad_w
        return result


def exact_hausdorff(a: PointCloud, b: PointCloud, comm: MPI.Comm = MPI.COMM_SELF) -> float:
    """Symmetric Hausdorff distance between two point sets (KD-tree)."""
    a_tree, b_tree = a.tree(comm), b.tree(comm)
    d_ab = b_tree.query(cellgrid.as3(a.points), k=1, workers=_kdtree_workers())[0]
    d_ba = a_tree.query(cellgrid.as3(b.points), k=1, workers=_kdtree_workers())[0]
    local = max(d_ab.max(initial=0.0), d_ba.max(initial=0.0))
    return comm.allreduce(float(local), MPI.MAX)

