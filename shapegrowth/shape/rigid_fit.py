"""A free body compared in its best-fit placement (``objective.placement: fitted``).

A body held only against rigid motion (``boundary.clamp: rigid``) stands where its three
pinned vertices put it, and those vertices are chosen from the mesh: the mesh refined for the
verification, or a target made on another mesh, pins other vertices and so tilts and moves
the same shape.  Here the compared cloud x_q is moved rigidly onto its own reference X_q
before it is compared,

    y_q = R^T (x_q - c) + C,   c = sum m_q x_q / M,   C = sum m_q X_q / M,
    R = polar(A),   A = sum m_q x_q (X_q - C)^T   (A = R U, U symmetric positive),

with the reference weights m_q: the least-squares (Kabsch) rotation and the centroid, linear
in x up to the polar factor, so the placement depends on the shape alone and converges with
the mesh.  A section of a body of revolution keeps its axis: only the axial translation is
fitted.  The derivative of a function with gradient g_q = dS/dy_q is

    dS/dx_p = R g_p - (m_p / M) R G + m_p D (X_p - C),   G = sum g_q,
    D = R [z]x (3D),  z = (tr U I - U)^-1 ax(M - M^T),  M = R^T K,  K = sum (x_q - c) g_q^T,

(2D: D = R J dtheta, dtheta = (M21 - M12) / tr U), from dR = R Omega and
Omega U + U Omega = R^T dA - dA^T R.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI


def _skew(z: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -z[2], z[1]], [z[2], 0.0, -z[0]], [-z[1], z[0], 0.0]])


def _axial(W: np.ndarray) -> np.ndarray:
    return np.array([W[2, 1], W[0, 2], W[1, 0]])


class RigidFit:
    """The placement y = R^T (x - c) + C of a cloud with reference points ``X`` and weights
    ``m`` (this rank's), summed over ``comm``; ``axial``: the axial translation only (a
    section (R, Z) of a body of revolution: the second coordinate)."""

    def __init__(self, X: np.ndarray, m: np.ndarray, comm: MPI.Comm, axial: bool = False):
        self.X, self.m, self.comm, self.axial = X, m, comm, axial
        self.dim = X.shape[1]
        sums = comm.allreduce(np.concatenate([[m.sum()], m @ X]), MPI.SUM)
        self.M, self.C = float(sums[0]), sums[1:] / sums[0]
        self.arm = X - self.C  # X_q - C
        self._last: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    def _sum(self, a: np.ndarray) -> np.ndarray:
        return self.comm.allreduce(a, MPI.SUM)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The placed points y (this rank's)."""
        c = self._sum(self.m @ x) / self.M
        if self.axial:
            R = np.eye(self.dim)
            U = np.eye(self.dim)
            shift = np.zeros(self.dim)
            shift[1] = self.C[1] - c[1]
            self._last = (R, U, c, x)
            return x + shift
        A = self._sum(np.einsum("q,qi,qj->ij", self.m, x, self.arm))
        W, s, Vt = np.linalg.svd(A)
        if np.linalg.det(W @ Vt) < 0:  # the nearest rotation, not a reflection
            W[:, -1] *= -1
            s[-1] *= -1
        R = W @ Vt
        U = Vt.T @ np.diag(s) @ Vt
        self._last = (R, U, c, x)
        return (x - c) @ R + self.C  # rows: R^T (x - c) + C

    def place(self, points: np.ndarray) -> np.ndarray:
        """Other points of the same body (e.g. a figure's vertices) moved as the last placed
        cloud was."""
        assert self._last is not None, "place a cloud first"
        R, _, c, _ = self._last
        if self.axial:
            out = np.array(points, dtype=float, copy=True)
            out[:, 1] += self.C[1] - c[1]
            return out
        return (points - c) @ R + self.C

    def pullback(self, g: np.ndarray) -> np.ndarray:
        """dS/dx (this rank's rows) from dS/dy at the last placement."""
        assert self._last is not None, "place a cloud first"
        R, U, c, x = self._last
        G = self._sum(g.sum(axis=0))
        if self.axial:
            out = g.copy()
            out[:, 1] -= self.m / self.M * G[1]
            return out
        out = g @ R.T - np.outer(self.m / self.M, R @ G)
        K = self._sum(np.einsum("qi,qj->ij", x - c, g))
        Mk = R.T @ K
        if self.dim == 3:
            T = np.trace(U) * np.eye(3) - U
            z = np.linalg.solve(T, _axial(Mk - Mk.T))
            D = R @ _skew(z)
        else:
            J = np.array([[0.0, -1.0], [1.0, 0.0]])
            D = R @ J * (Mk[1, 0] - Mk[0, 1]) / np.trace(U)
        return out + self.m[:, None] * (self.arm @ D.T)
