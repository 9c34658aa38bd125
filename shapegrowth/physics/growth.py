"""The growth tensor C_g = sum_i lambda_i v_i (x) v_i of (5.2).

The eigenvalues lambda_i (and, for ``frame: free``, the Rodrigues angles
theta_i of (5.3)-(5.4)) are scalar dolfinx Functions; the eigenvectors come
from the frame:

* ``cartesian``: v_i = E_i;
* ``cylindrical`` (about X3, Fig. 6): v1 = [cos t, sin t, 0], v2 = [-sin t, cos t, 0], v3 = E3;
* ``tube`` (about X1, Fig. 2b): v1 = E1, v2 = [0, -sin t, cos t], v3 = [0, cos t, sin t];
* ``free``: the columns of V = I - sin t3 K + (1 - cos t3) K K, K_ij = e_ijk k_k,
  k = [cos t1 sin t2, sin t1 sin t2, cos t2]; in 2D one angle a rotates the plane
  frame, v1 = [cos a, sin a], v2 = [-sin a, cos a].

With ``incompressible`` the last eigenvalue is 1 / (product of the others), so
det C_g = 1.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import dolfinx.fem
import numpy as np
import ufl
from mpi4py import MPI

from .. import compat
from ..config import Config, ConfigError, resolved
from ..config.expressions import evaluate
from ..config.maps import target_metric
from ..config.reduction import Section
from .eigenframes import aligned_eigenframes, one_hemisphere, rodrigues_angles

log = logging.getLogger(__name__)


class Growth:
    """Eigenvalue and angle fields on a mesh, and the C_g they define."""

    def __init__(self, mesh, dim: int, frame: str, degree: int = 1,
                 incompressible: bool = False, section: Section | None = None):
        self.mesh, self.dim, self.frame = mesh, dim, frame
        self.degree, self.incompressible = degree, incompressible
        # a section of a 3D body: mesh point (X1, X3) stands for (X1, 0, X3) (reduction.py)
        self.section = section if section is not None and section.reduced else None
        self.space = compat.scalar_space(mesh, degree)
        n_eig = dim - 1 if incompressible else dim
        self.eigenvalues = [dolfinx.fem.Function(self.space, name=f"lambda_hat_{i + 1}")
                            for i in range(n_eig)]
        n_ang = (3 if dim == 3 else 1) if frame == "free" else 0
        self.angles = [dolfinx.fem.Function(self.space, name=f"theta_hat_{i + 1}")
                       for i in range(n_ang)]
        for f in self.eigenvalues:
            f.x.array[:] = 1.0

    @classmethod
    def from_config(cls, mesh, cfg: Config) -> Growth:
        g = cfg.growth
        growth = cls(mesh, cfg.growth_dim, g.frame, resolved(g.degree),
                     g.eigenvalues.incompressible, cfg.section)
        growth.initialise(cfg)
        return growth

    def like(self) -> Growth:
        """New fields on the same spaces and frame (values: identity growth)."""
        return Growth(self.mesh, self.dim, self.frame, self.degree, self.incompressible,
                      self.section)

    def point(self) -> ufl.core.expr.Expr:
        """The reference point (UFL) the frame is evaluated at: 3D for a section."""
        x = ufl.SpatialCoordinate(self.mesh)
        return ufl.as_vector([x[0], 0.0, x[1]]) if self.section is not None else x

    def node_points(self) -> np.ndarray:
        """The reference points (3, n) of the growth's nodes (3D for a section)."""
        x = self.space.tabulate_dof_coordinates().T
        return self.section.embed(x) if self.section is not None else x

    # ---- values ----------------------------------------------------------------------------
    @property
    def fields(self) -> list[dolfinx.fem.Function]:
        return [*self.eigenvalues, *self.angles]

    def values(self) -> list[np.ndarray]:
        return [f.x.array.copy() for f in self.fields]

    def assign(self, values: Sequence[np.ndarray]) -> None:
        for f, v in zip(self.fields, values):
            f.x.array[:] = v

    def identity_values(self) -> list[np.ndarray]:
        """Values of the identity growth C_g = I (angles kept: they act on nothing)."""
        return [np.ones_like(f.x.array) for f in self.eigenvalues] + \
               [f.x.array.copy() for f in self.angles]

    def blend(self, start: Sequence[np.ndarray], end: Sequence[np.ndarray],
              t: float) -> list[np.ndarray]:
        """Growth a fraction t of the way from ``start`` to ``end``.

        Eigenvalues move geometrically (lambda = lambda_s^(1-t) lambda_e^t), a
        uniform ramp in logarithmic strain that keeps them positive; angles move
        linearly.
        """
        if t == 1.0:  # exactly the end: the state must balance the requested growth itself
            return [b.copy() for b in end]
        n = len(self.eigenvalues)
        out = [np.exp((1 - t) * np.log(a) + t * np.log(b)) for a, b in zip(start[:n], end[:n])]
        out += [(1 - t) * a + t * b for a, b in zip(start[n:], end[n:])]
        return out

    def initialise(self, cfg: Config) -> None:
        """Set the fields from the config's numbers or expressions, checking the bounds."""
        g = cfg.growth
        x = self.node_points()
        params, axis = cfg.expression_params, cfg.cylinder_axis
        problems: list[str] = []
        lo, hi = g.eigenvalues.bounds
        for i, (f, value) in enumerate(zip(self.eigenvalues, resolved(g.eigenvalues.initial))):
            f.x.array[:] = evaluate(value, x, params, axis)
            _check_bounds(f, lo, hi, f"growth.eigenvalues.initial[{i}]", problems)
        for i, (f, value) in enumerate(zip(self.angles, resolved(g.angles.initial))):
            f.x.array[:] = evaluate(value, x, params, axis)
            a_lo, a_hi = resolved(g.angles.bounds)[i]
            _check_bounds(f, a_lo, a_hi, f"growth.angles.initial[{i}]", problems)
        if g.start == "target":
            self._start_from_target(cfg, x, problems)
        if problems:
            raise ConfigError(problems)

    def _start_from_target(self, cfg: Config, x: np.ndarray, problems: list[str]) -> None:
        """The target map's metric C_d = grad Phi_d^T grad Phi_d at the growth nodes: the
        growth that would make Phi_d itself stress-free, seen through this frame.  A fixed
        frame keeps v_i . C_d v_i; the free frame takes C_d's eigenvalues and directions.
        Values outside the bounds are clipped (where Phi_d is singular, e.g. at corners)."""
        C = target_metric(cfg, x)
        if not np.isfinite(C).all():
            problems.append("growth.start: the target map's gradient is not finite "
                            "everywhere on the body")
            return
        if self.frame == "free" and self.dim == 3:
            lams = self._free_frame_from_metric(cfg, x, C)
        elif self.frame == "free":
            w, vecs = np.linalg.eigh(C)
            lams = [w[:, 1], w[:, 0]]
            a_lo, a_hi = resolved(cfg.growth.angles.bounds)[0]
            angle = np.arctan2(vecs[:, 1, 1], vecs[:, 0, 1])  # v1 and -v1: the same frame
            self.angles[0].x.array[:] = np.minimum(a_lo + np.mod(angle - a_lo, np.pi), a_hi)
        else:
            vectors = self._frame_values()
            lams = [np.einsum("nj,njk,nk->n", v, C, v) for v in vectors]
        lo, hi = cfg.growth.eigenvalues.bounds
        clipped = 0
        for f, lam in zip(self.eigenvalues, lams):
            clipped += int(np.count_nonzero((lam < lo) | (lam > hi)))
            f.x.array[:] = np.clip(lam, lo, hi)
        comm = self.mesh.comm
        clipped, total = comm.allreduce(clipped), comm.allreduce(len(lams[0]) * len(lams))
        if clipped:
            log.info("growth.start: target: %d of %d nodal eigenvalues clipped to [%g, %g]",
                     clipped, total, lo, hi)

    def _free_frame_from_metric(self, cfg: Config, x: np.ndarray,
                                C: np.ndarray) -> list[np.ndarray]:
        """The free 3D frame: C_d's eigenvalues and Rodrigues angles, their frames aligned
        from node to node (eigenframes.py), on rank 0 for the whole body, so that 1 and N
        ranks choose the same frames.  Sets the angles; returns the eigenvalues."""
        comm = self.mesh.comm
        owned = self.space.dofmap.index_map.size_local
        pieces = comm.gather((x.T[:owned], C[:owned]), root=0)
        if comm.rank == 0:
            xs = np.concatenate([p[0] for p in pieces])
            Cs = np.concatenate([p[1] for p in pieces])
            lams, frames = aligned_eigenframes(Cs, xs)
            t = rodrigues_angles(frames)
            signed = one_hemisphere(*t)
            if resolved(cfg.growth.angles.bounds)[2][0] < 0:  # t3 may be signed
                t = signed
            elif np.any(signed[2] < -1e-8):
                log.info("growth.start: target: the frames turn both ways about one axis, "
                         "and their angles jump where the turn changes sign; with "
                         "growth.angles.bounds' third pair from -pi (e.g. [-3.1416, 3.1416]) "
                         "they stay continuous (eigenframes.py, one_hemisphere)")
            angles = np.stack(t, axis=1)
            counts = np.cumsum([0] + [len(p[0]) for p in pieces])
            parts = [(lams[a:b], angles[a:b]) for a, b in zip(counts[:-1], counts[1:])]
        else:
            parts = None
        lam_own, ang_own = comm.scatter(parts, root=0)
        for i, f in enumerate(self.angles):
            a_lo, a_hi = resolved(cfg.growth.angles.bounds)[i]
            f.x.array[:owned] = np.clip(ang_own[:, i], a_lo, a_hi)
            f.x.scatter_forward()
        # the eigenvalue fields carry the values to the ghosts; the caller clips them
        for i, f in enumerate(self.eigenvalues):
            f.x.array[:owned] = lam_own[:, i]
            f.x.scatter_forward()
        return [f.x.array.copy() for f in self.eigenvalues]

    def _frame_values(self) -> list[np.ndarray]:
        """The frame's v_i at the growth nodes, each (n, dim)."""
        scratch = dolfinx.fem.Function(self.space)
        out = []
        for v in frame_vectors(self.frame, self.point(), self.dim):
            components = []
            for k in range(self.dim):
                compat.interpolate_expression(scratch, v[k])
                components.append(scratch.x.array.copy())
            out.append(np.stack(components, axis=1))
        return out

    # ---- UFL -------------------------------------------------------------------------------
    def eigenvalue_exprs(self) -> list[ufl.core.expr.Expr]:
        lams: list[ufl.core.expr.Expr] = list(self.eigenvalues)
        if self.incompressible:
            product = lams[0]
            for lam in lams[1:]:
                product = product * lam
            lams.append(1 / product)
        return lams

    def vectors(self) -> list[ufl.core.expr.Expr]:
        """The eigenvectors v_i as UFL vectors."""
        return frame_vectors(self.frame, self.point(), self.dim, self.angles)

    def inverse_root(self) -> ufl.core.expr.Expr:
        """G^-1 = C_g^(-1/2) = sum_i lambda_i^(-1/2) v_i (x) v_i."""
        lams = self.eigenvalue_exprs()
        return sum((lam ** -0.5 * ufl.outer(v, v) for lam, v in zip(lams, self.vectors())),
                   ufl.zero(self.dim, self.dim))

    def tensor(self) -> ufl.core.expr.Expr:
        """C_g (dim x dim) as a UFL expression of the fields."""
        lams = self.eigenvalue_exprs()
        if self.frame == "cartesian":
            return ufl.diag(ufl.as_vector(lams))
        vs = self.vectors()
        return sum((lam * ufl.outer(v, v) for lam, v in zip(lams, vs)),
                   ufl.zero(self.dim, self.dim))


def frame_vectors(frame: str, x: ufl.core.expr.Expr, dim: int,
                  angles: Sequence[ufl.core.expr.Expr] = ()) -> list[ufl.core.expr.Expr]:
    """Eigenvectors of the frame at reference point x (UFL)."""
    if frame == "cartesian":
        return [ufl.as_vector([1.0 if j == i else 0.0 for j in range(dim)]) for i in range(dim)]
    if frame == "cylindrical":
        r = ufl.sqrt(x[0] ** 2 + x[1] ** 2)
        c, s = x[0] / r, x[1] / r
        if dim == 2:
            return [ufl.as_vector([c, s]), ufl.as_vector([-s, c])]
        return [ufl.as_vector([c, s, 0]), ufl.as_vector([-s, c, 0]), ufl.as_vector([0, 0, 1])]
    if frame == "tube":
        r = ufl.sqrt(x[1] ** 2 + x[2] ** 2)
        c, s = x[1] / r, x[2] / r
        return [ufl.as_vector([1, 0, 0]), ufl.as_vector([0, -s, c]), ufl.as_vector([0, c, s])]
    if frame == "free":
        if dim == 2:
            (a,) = angles
            return [ufl.as_vector([ufl.cos(a), ufl.sin(a)]),
                    ufl.as_vector([-ufl.sin(a), ufl.cos(a)])]
        V = rodrigues(*angles)
        return [ufl.as_vector([V[0, i], V[1, i], V[2, i]]) for i in range(3)]
    raise ValueError(f"unknown frame {frame!r}")


def rodrigues(t1, t2, t3) -> ufl.core.expr.Expr:
    """V(k, t3) of (5.3) with k(t1, t2) of (5.4); its columns are v1, v2, v3."""
    k = [ufl.cos(t1) * ufl.sin(t2), ufl.sin(t1) * ufl.sin(t2), ufl.cos(t2)]
    K = ufl.as_matrix([[0, k[2], -k[1]], [-k[2], 0, k[0]], [k[1], -k[0], 0]])
    return ufl.Identity(3) - ufl.sin(t3) * K + (1 - ufl.cos(t3)) * K * K


def _check_bounds(f: dolfinx.fem.Function, lo: float, hi: float, key: str,
                  problems: list[str]) -> None:
    comm = f.function_space.mesh.comm
    n = f.function_space.dofmap.index_map.size_local
    local = f.x.array[:n]
    fmin = comm.allreduce(local.min() if n else np.inf, MPI.MIN)
    fmax = comm.allreduce(local.max() if n else -np.inf, MPI.MAX)
    if not (np.isfinite(fmin) and np.isfinite(fmax)):
        problems.append(f"{key}: the expression is not finite everywhere on the body")
    elif fmin < lo - 1e-12 or fmax > hi + 1e-12:
        problems.append(f"{key}: takes values in [{fmin:.6g}, {fmax:.6g}], outside the bounds "
                        f"[{lo}, {hi}]")
