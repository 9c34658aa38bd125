"""The free 3D frame from a metric field: Rodrigues angles of a rotation and back, and
eigenframes that vary continuously from node to node (eigenframes.py)."""

from __future__ import annotations

import numpy as np
import pytest

from shapegrowth.physics.eigenframes import aligned_eigenframes, rodrigues_angles, rodrigues_matrix


def _rotations(n: int, seed: int = 0) -> np.ndarray:
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(n, 3, 3)))
    q[np.linalg.det(q) < 0, :, 0] *= -1
    return q


def _twist_metric(x: np.ndarray, tau: float, c: float) -> np.ndarray:
    """C_d of a section-wise rotation by tau x1 about the line (x2, x3) = (-c, 0)."""
    a = tau * np.stack([np.zeros(len(x)), -x[:, 2], x[:, 1] + c], axis=1)
    C = np.tile(np.eye(3), (len(x), 1, 1))
    C[:, 0, :] += a
    C[:, :, 0] += a
    C[:, 0, 0] += (a * a).sum(axis=1)
    return C


def test_rodrigues_angles_invert_the_matrix_of_5_3():
    """Random rotations, the identity, and half turns about the axes and a diagonal: the
    angles lie in the paper's bounds and give the rotation back to round-off."""
    half = [2 * np.outer(k, k) - np.eye(3) for k in
            (np.eye(3)[0], np.eye(3)[1], np.eye(3)[2], np.ones(3) / np.sqrt(3))]
    V = np.concatenate([_rotations(500), np.eye(3)[None], np.array(half)])
    t1, t2, t3 = rodrigues_angles(V)
    assert np.abs(rodrigues_matrix(t1, t2, t3) - V).max() < 1e-10
    assert (0 <= t1).all() and (t1 < 2 * np.pi).all()
    assert (0 <= t2).all() and (t2 <= np.pi).all() and (0 <= t3).all() and (t3 <= np.pi).all()


def test_aligned_eigenframes_decompose_every_metric():
    """C = V diag(lambda) V^T with V a rotation, at every node of a random SPD field."""
    rng = np.random.default_rng(1)
    A = rng.normal(size=(300, 3, 3))
    C = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(3)
    lams, V = aligned_eigenframes(C, rng.uniform(size=(300, 3)))
    assert np.abs(np.einsum("nij,nj,nkj->nik", V, lams, V) - C).max() < 1e-10
    assert np.allclose(np.linalg.det(V), 1.0)
    assert np.abs(V.transpose(0, 2, 1) @ V - np.eye(3)).max() < 1e-12


def _grid(x2: np.ndarray, x3: np.ndarray) -> np.ndarray:
    g1, g2, g3 = np.meshgrid(np.linspace(0, 1, 11), x2, x3, indexing="ij")
    return np.stack([g1.ravel(), g2.ravel(), g3.ravel()], axis=1)


def test_frames_turn_continuously_where_eigenvalues_cross():
    """The strip twisted about its own centre line, on its mid-plane x3 = 0: C_d's
    eigenvalues cross at x2 = 0 (C_d = I there), where sorting them turns the frame by 90
    degrees.  Aligned, the frame stays the same rotation (a tilt about E2) across the strip
    and lambda_1 runs smoothly through 1."""
    x = _grid(np.linspace(-0.05, 0.05, 11), np.zeros(1))
    lams, V = aligned_eigenframes(_twist_metric(x, np.pi / 2, 0.0), x)
    t = np.stack(rodrigues_angles(V), axis=1)
    assert np.ptp(t[:, :2], axis=0).max() < 1e-8  # one axis, +-E2
    assert np.ptp(t[:, 2]) < 0.05  # the tilt, atan(2 / b) / 2, changes by ~b/2 (b = 0.08)
    lam1 = lams[:, 0].reshape(11, 11)[5]  # along x2 at x1 = 0.5
    assert np.all(np.diff(lam1) < 0)  # through 1 at x2 = 0, no fold
    sorted_lam1 = np.linalg.eigvalsh(_twist_metric(x, np.pi / 2, 0.0))[:, 2].reshape(11, 11)[5]
    assert np.any(np.diff(sorted_lam1) > 0)  # sorting folds it


def test_frames_of_the_off_axis_twist_are_smooth_and_numbering_free():
    """The reachable twist (configs/reachable/twist.yaml): between neighbouring nodes of a
    0.01 grid the frame turns by no more than the twist's own direction e_theta does
    (0.01 / 0.05 rad at the edge nearest the axis; sorted eigenvalues would jump by pi/2
    nowhere here, but a frame chosen node by node may flip), and the nodes taken in another
    order get the same frames."""
    x = _grid(np.linspace(-0.05, 0.05, 11), np.linspace(-0.01, 0.01, 3))
    C = _twist_metric(x, np.pi / 2, 0.1)
    lams, V = aligned_eigenframes(C, x)
    grid = V.reshape(11, 11, 3, 3, 3)
    for axis in range(3):
        a = np.moveaxis(grid, axis, 0)
        turn = np.einsum("...ji,...jk->...ik", a[:-1], a[1:])  # V_a^T V_b
        angle = np.arccos(np.clip((np.trace(turn, axis1=-2, axis2=-1) - 1) / 2, -1, 1))
        assert angle.max() < 0.21
    perm = np.random.default_rng(2).permutation(len(x))
    lams_p, V_p = aligned_eigenframes(C[perm], x[perm])
    assert np.allclose(lams_p, lams[perm], atol=1e-12) and np.allclose(V_p, V[perm], atol=1e-12)


@pytest.mark.parametrize("tau", [0.5, 3.0])
def test_the_twist_metric_is_isochoric(tau):
    """det C_d = 1 (a rigid turn of each section): the eigenvalues multiply to 1."""
    x = _grid(np.linspace(-0.05, 0.05, 5), np.linspace(-0.01, 0.01, 3))
    lams, _ = aligned_eigenframes(_twist_metric(x, tau, 0.1), x)
    assert np.allclose(lams.prod(axis=1), 1.0)


def test_one_hemisphere_keeps_each_rotation_and_the_turn_about_one_axis_continuous():
    """The rotation by t3 about k is the rotation by -t3 about -k: every rotation is kept;
    a frame field turning both ways about X3 (the disk's in-plane directions) keeps its axis
    at +X3 with t3 signed, so that the angles halfway between +a and -a are the identity
    (unsigned, the axis jumps to -X3 and halfway is a turn about a horizontal axis)."""
    from shapegrowth.physics.eigenframes import one_hemisphere

    V = _rotations(400, seed=3)
    t = one_hemisphere(*rodrigues_angles(V))
    assert np.abs(rodrigues_matrix(*t) - V).max() < 1e-10
    k = np.stack([np.sin(t[1]) * np.cos(t[0]), np.sin(t[1]) * np.sin(t[0]), np.cos(t[1])], 1)
    weight = np.sin(t[2] / 2) ** 2
    leading = np.linalg.eigh(np.einsum("n,ni,nj->ij", weight, k, k))[1][:, -1]
    assert (k @ leading * np.sign(leading[np.argmax(np.abs(leading))]) >= 0).all()
    turns = np.linspace(-1.2, 1.2, 9)  # about X3, both ways
    c, s = np.cos(turns), np.sin(turns)
    Z = np.zeros((len(turns), 3, 3))
    Z[:, 0, 0], Z[:, 0, 1], Z[:, 1, 0], Z[:, 1, 1], Z[:, 2, 2] = c, -s, s, c, 1.0
    unsigned = rodrigues_angles(Z)
    assert np.ptp(np.cos(unsigned[1])) == pytest.approx(2.0)  # the axis jumps, +X3 to -X3
    t1, t2, t3 = one_hemisphere(*unsigned)
    assert np.abs(rodrigues_matrix(t1, t2, t3) - Z).max() < 1e-12
    assert np.abs(t2).max() < 1e-12 and t3 == pytest.approx(turns, abs=1e-12)
    half = [(a[0] + a[-1]) / 2 for a in (t1, t2, t3)]  # between the turns by -1.2 and +1.2
    assert np.abs(rodrigues_matrix(*[np.array([h]) for h in half])[0] - np.eye(3)).max() < 1e-12
    wrong = [(a[0] + a[-1]) / 2 for a in unsigned]
    assert np.abs(rodrigues_matrix(*[np.array([h]) for h in wrong])[0] - np.eye(3)).max() > 0.5
