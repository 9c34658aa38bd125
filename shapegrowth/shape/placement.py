"""Where a target file lands (``target.transform``): units, rotation, position, and an
optional rigid alignment: of its principal axes of inertia onto the body's, or its best fit
to the body by iterated closest points.

The affine part acts on the file's nodes before the cloud is sampled, so the cloud's
weights carry the scaling's Jacobian.  The alignment moves the target rigidly: its
centroid onto the body's reference centroid, its principal axes (eigenvectors of the
central second-moment tensor, by increasing moment) onto the body's.  Each axis has two
signs; of the four sign choices that are rotations, the one whose clouds lie closest
(mean nearest-neighbour distance, both ways) is taken.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..config import ConfigError, TransformConfig

DISTINCT = 1e-3  # principal moments closer than this (relative) leave the axes undefined
SAMPLE = 20000  # at most this many points of each cloud choose the axes' signs


def rotation_matrix(degrees: tuple[float, ...]) -> np.ndarray:
    """R = R3 R2 R1: about X1 by degrees[0], then X2, then X3 (fixed axes)."""
    R = np.eye(3)
    for axis, angle in enumerate(np.radians(np.asarray(degrees, dtype=float))):
        c, s = np.cos(angle), np.sin(angle)
        i, j = (axis + 1) % 3, (axis + 2) % 3  # right-handed about the axis
        step = np.eye(3)
        step[i, i], step[i, j], step[j, i], step[j, j] = c, -s, s, c
        R = step @ R
    return R


def affine(nodes: np.ndarray, transform: TransformConfig) -> np.ndarray:
    """x -> R (s x) + t on (n, dim) nodes (a 2D file uses the X1-X2 block of R)."""
    dim = nodes.shape[1]
    scale = np.broadcast_to(np.asarray(transform.scale, dtype=float), (3,))
    R = rotation_matrix(transform.rotation)[:dim, :dim]
    t = np.asarray(transform.translation, dtype=float)[:dim]
    return (nodes * scale[:dim]) @ R.T + t


@dataclass(frozen=True)
class Moments:
    """Mass, centroid and central second moments (dim x dim) of a weighted cloud."""

    mass: float
    centroid: np.ndarray
    second: np.ndarray

    @classmethod
    def of(cls, points: np.ndarray, weights: np.ndarray, comm=None) -> Moments:
        """Of the cloud (summed over ``comm``'s ranks when given)."""
        sums = np.concatenate([[weights.sum()], weights @ points,
                               np.einsum("q,qi,qj->ij", weights, points, points).ravel()])
        if comm is not None:
            from mpi4py import MPI
            sums = comm.allreduce(sums, MPI.SUM)
        dim = points.shape[1]
        mass, first = float(sums[0]), sums[1:1 + dim]
        centroid = first / mass
        second = sums[1 + dim:].reshape(dim, dim) / mass - np.outer(centroid, centroid)
        return cls(mass, centroid, second)

    def axes(self, what: str) -> np.ndarray:
        """Principal axes (columns) by increasing moment; distinct moments required."""
        values, vectors = np.linalg.eigh(self.second)
        gaps = np.diff(values) / max(values[-1], 1e-300)
        if np.any(gaps < DISTINCT):
            raise ConfigError([
                f"target.transform.align: the {what}'s principal moments of inertia "
                f"{np.array2string(values, precision=4)} are not distinct, so its principal "
                "axes are not defined; place the target with rotation and translation instead"])
        return vectors


def principal_alignment(target: tuple[np.ndarray, np.ndarray],
                        body: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) moving the target cloud (points, weights) rigidly, x -> R x + t, so that its
    centroid and principal axes fall on the body's (both clouds whole, on every rank)."""
    mt, mb = Moments.of(*target), Moments.of(*body)
    Et, Eb = mt.axes("target"), mb.axes("body")
    dim = len(mt.centroid)
    tree_body = cKDTree(_sample(body[0]))
    target_sample = _sample(target[0]) - mt.centroid
    best: tuple[float, np.ndarray] | None = None
    for signs in np.array(np.meshgrid(*[[1.0, -1.0]] * dim)).reshape(dim, -1).T:
        R = Eb @ np.diag(signs) @ Et.T
        if np.linalg.det(R) < 0:
            continue
        moved = target_sample @ R.T + mb.centroid
        distance = tree_body.query(moved)[0].mean() + cKDTree(moved).query(
            _sample(body[0]))[0].mean()
        if best is None or distance < best[0] - 1e-12:
            best = (distance, R)
    assert best is not None
    R = best[1]
    return R, mb.centroid - R @ mt.centroid


def best_fit(target: tuple[np.ndarray, np.ndarray], body: tuple[np.ndarray, np.ndarray],
             normals: np.ndarray | None = None, iterations: int = 200,
             tolerance: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) moving the target cloud (points, weights) rigidly, x -> R x + t, onto the body
    cloud (both whole, on every rank) by iterated closest points, a local fit from where the
    target lies: each target point paired with its nearest body point, then the rigid motion
    that minimises the weighted squared distances to the body's tangent planes there
    (``normals``: the body's unit normals; Gauss-Newton on a small rotation and translation),
    or without normals to the points themselves (Kabsch); until the motion stops moving.
    Point to plane converges where point to point stalls on a shallow surface (a saddle over
    a square turned by 6 degrees: 7e-6 against 0.03, measured)."""
    points, weights = target
    dim = points.shape[1]
    tree = cKDTree(body[0])
    R, t = np.eye(dim), np.zeros(dim)
    for _ in range(iterations):
        moved = points @ R.T + t
        nearest = tree.query(moved)[1]
        q = body[0][nearest]
        if normals is None:
            centre = weights @ moved / weights.sum()
            W, _, Vt = np.linalg.svd(np.einsum("q,qi,qj->ij", weights, q - weights @ q /
                                               weights.sum(), moved - centre))
            if np.linalg.det(W @ Vt) < 0:
                W[:, -1] *= -1
            step = W @ Vt
            shift = weights @ q / weights.sum() - step @ centre
        else:
            n = normals[nearest]
            centre = weights @ moved / weights.sum()  # turned about it (conditioning)
            arm = moved - centre
            turn = np.cross(arm, n) if dim == 3 else \
                (arm[:, 0] * n[:, 1] - arm[:, 1] * n[:, 0])[:, None]
            rows = np.sqrt(weights)[:, None] * np.column_stack([turn, n])
            gap = np.sqrt(weights) * np.einsum("qi,qi->q", q - moved, n)
            x = np.linalg.lstsq(rows, gap, rcond=None)[0]  # a flat body's slide: left as is
            step = _rotation(x[:-dim], dim)
            shift = x[-dim:] + centre - step @ centre
        R, t = step @ R, step @ t + shift
        if np.abs(step - np.eye(dim)).max() < tolerance and np.abs(shift).max() < tolerance:
            break
    return R, t


def _rotation(omega: np.ndarray, dim: int) -> np.ndarray:
    """The rotation by the vector ``omega`` (3D, Rodrigues) or the angle omega[0] (2D)."""
    if dim == 2:
        c, s = np.cos(omega[0]), np.sin(omega[0])
        return np.array([[c, -s], [s, c]])
    angle = float(np.linalg.norm(omega))
    if angle == 0.0:
        return np.eye(3)
    k = omega / angle
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _sample(points: np.ndarray) -> np.ndarray:
    stride = max(1, len(points) // SAMPLE)
    return points[::stride]
