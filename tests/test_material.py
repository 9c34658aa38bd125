"""psi (5.1) in UFL: its automatic derivatives against the paper's closed forms.

P = dpsi/dF against (5.9), d2psi/dF2 against the elasticity tensor of Sect.
5.1.3, d(P : grad p)/dC_g against T of (5.13), all at random F and C_g to
round-off; stress-free exactly when F^T F = C_g; frame invariance and isotropy.
"""

from __future__ import annotations

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from mpi4py import MPI

from shapegrowth import compat
from shapegrowth.physics import closed_forms as cf
from shapegrowth.physics.material import MooneyRivlin

MAT = MooneyRivlin(mu1=0.7, mu2=0.3, lmbda=3.0)  # unequal mu's so a swapped term shows
RNG = np.random.default_rng(20240323)


class Pointwise:
    """Evaluate UFL expressions of constant 3x3 tensors F, C_g, grad p."""

    def __init__(self):
        self.mesh = dolfinx.mesh.create_unit_cube(MPI.COMM_SELF, 1, 1, 1)
        self.F = dolfinx.fem.Constant(self.mesh, np.eye(3))
        self.Cg = dolfinx.fem.Constant(self.mesh, np.eye(3))
        self.gp = dolfinx.fem.Constant(self.mesh, np.zeros((3, 3)))
        self._compiled = {}

    def __call__(self, name, build, F, Cg, gp=np.zeros((3, 3))):
        self.F.value[:], self.Cg.value[:], self.gp.value[:] = F, Cg, gp
        if name not in self._compiled:
            expr = build(self.F, self.Cg, self.gp)
            self._compiled[name] = (compat.expression_evaluator(
                expr, np.array([[0.2, 0.2, 0.2]]), self.mesh, [0]), expr.ufl_shape)
        compiled, shape = self._compiled[name]
        return compiled().reshape(shape)


@pytest.fixture(scope="module")
def pw():
    return Pointwise()


def stress(F, Cg, gp):
    Fv = ufl.variable(F)
    return ufl.diff(MAT.psi(Fv, Cg), Fv)


def tangent(F, Cg, gp):
    Fv = ufl.variable(F)
    return ufl.diff(ufl.diff(MAT.psi(Fv, Cg), Fv), Fv)


def growth_sensitivity(F, Cg, gp):
    Fv, Cv = ufl.variable(F), ufl.variable(Cg)
    return ufl.diff(ufl.inner(ufl.diff(MAT.psi(Fv, Cv), Fv), gp), Cv)


def energy(F, Cg, gp):
    return MAT.psi(F, Cg)


def random_F():
    F = np.eye(3) + 0.3 * RNG.standard_normal((3, 3))
    return F if np.linalg.det(F) > 0.2 else random_F()


def random_Cg():
    Q = rotation(RNG.standard_normal(3))
    return Q @ np.diag(RNG.uniform(0.3, 4.0, 3)) @ Q.T


def rotation(w):
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    theta = np.linalg.norm(w)
    K = K / theta
    return np.eye(3) + np.sin(theta) * K + (1 - np.cos(theta)) * K @ K


def closed_args():
    return dict(mu1=MAT.mu1, mu2=MAT.mu2, lmbda=MAT.lmbda)


@pytest.mark.parametrize("trial", range(5))
def test_stress_matches_5_9(pw, trial):
    F, Cg = random_F(), random_Cg()
    P = pw("P", stress, F, Cg)
    expected = cf.stress(F, Cg, **closed_args())
    assert np.allclose(P, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("trial", range(3))
def test_tangent_matches_elasticity_tensor(pw, trial):
    F, Cg = random_F(), random_Cg()
    C = pw("C", tangent, F, Cg)
    expected = cf.elasticity(F, Cg, **closed_args())
    assert np.allclose(C, expected, rtol=1e-11, atol=1e-11 * np.abs(expected).max())
    # major symmetry: the tangent is a second derivative
    assert np.allclose(C, C.transpose(2, 3, 0, 1), atol=1e-12 * np.abs(C).max())


@pytest.mark.parametrize("trial", range(3))
def test_growth_sensitivity_matches_5_13(pw, trial):
    F, Cg, gp = random_F(), random_Cg(), RNG.standard_normal((3, 3))
    T = pw("T", growth_sensitivity, F, Cg, gp)
    expected = cf.growth_sensitivity(F, Cg, gp, **closed_args())
    # (5.13) differentiates (5.9) over all 3x3 C_g; UFL's P carries F (cof C + cof C^T)/2,
    # which equals (5.9) on symmetric C_g, so its C_g-derivative is the symmetric part of T.
    # Only symmetric directions dC_g = v (x) v ever meet T, where the two agree.
    sym = 0.5 * (expected + expected.T)
    assert np.allclose(T, sym, rtol=1e-11, atol=1e-11 * np.abs(expected).max())


def test_eigenvalue_derivative_is_v_T_v(pw):
    """d(P : grad p)/dlambda_i = v_i . T v_i (Sect. 5.1.3), by central differences."""
    F, gp = random_F(), RNG.standard_normal((3, 3))
    V = rotation(RNG.standard_normal(3))
    lam = RNG.uniform(0.5, 3.0, 3)
    T = cf.growth_sensitivity(F, V @ np.diag(lam) @ V.T, gp, **closed_args())
    for i in range(3):
        h = 1e-5 * lam[i]
        values = []
        for sign in (1, -1):
            lam_h = lam.copy()
            lam_h[i] += sign * h
            P = cf.stress(F, V @ np.diag(lam_h) @ V.T, **closed_args())
            values.append(np.sum(P * gp))
        fd = (values[0] - values[1]) / (2 * h)
        assert fd == pytest.approx(V[:, i] @ T @ V[:, i], rel=1e-7)


def test_angle_derivative_carries_the_eigenvalues():
    """d(P : grad p)/dtheta_i = sum_j lambda_j dv_j/dtheta_i . (T + T^T) v_j, by central
    differences through (5.5): C_g = sum_j lambda_j v_j (x) v_j, so each term carries its
    lambda_j.  The paper's printed sensitivity (Sect. 5.1.3) omits lambda_j; it is right
    only where every lambda_j = 1, and here it is not."""
    F, gp = random_F(), RNG.standard_normal((3, 3))
    lam = np.array([0.6, 1.7, 2.9])
    theta = RNG.uniform(0.3, 1.2, 3)

    def metric(t):
        V = cf.rodrigues_vectors(*t)  # rows v1, v2, v3
        return sum(lam[j] * np.outer(V[j], V[j]) for j in range(3))

    V = cf.rodrigues_vectors(*theta)
    T = cf.growth_sensitivity(F, metric(theta), gp, **closed_args())
    for i in range(3):
        h = 1e-6
        up, down = theta.copy(), theta.copy()
        up[i] += h
        down[i] -= h
        fd = (np.sum(cf.stress(F, metric(up), **closed_args()) * gp)
              - np.sum(cf.stress(F, metric(down), **closed_args()) * gp)) / (2 * h)
        dV = (cf.rodrigues_vectors(*up) - cf.rodrigues_vectors(*down)) / (2 * h)
        terms = [dV[j] @ (T + T.T) @ V[j] for j in range(3)]
        assert fd == pytest.approx(sum(lam[j] * terms[j] for j in range(3)), rel=1e-6)
        assert fd != pytest.approx(sum(terms), rel=1e-2)  # the printed form


@pytest.mark.parametrize("trial", range(3))
def test_stress_free_when_FtF_equals_Cg(pw, trial):
    Cg = random_Cg()
    w, Q = np.linalg.eigh(Cg)
    F = rotation(RNG.standard_normal(3)) @ Q @ np.diag(np.sqrt(w)) @ Q.T
    P = pw("P", stress, F, Cg)
    assert np.abs(P).max() < 1e-12


def test_frame_invariance_and_isotropy(pw):
    F, Cg = random_F(), random_Cg()
    Q = rotation(RNG.standard_normal(3))
    psi = pw("psi", energy, F, Cg)
    assert pw("psi", energy, Q @ F, Cg) == pytest.approx(psi, rel=1e-13)
    # psi(F Q^T, Q C_g Q^T) = psi(F, C_g): W0 is isotropic
    assert pw("psi", energy, F @ Q.T, Q @ Cg @ Q.T) == pytest.approx(psi, rel=1e-12)
    P, PQ = pw("P", stress, F, Cg), pw("P", stress, Q @ F, Cg)
    assert np.allclose(PQ, Q @ P, atol=1e-12 * np.abs(P).max())


def test_energy_is_W0_of_elastic_part(pw):
    """psi(F, C_g) = W0(F G^-1) det G with G = C_g^(1/2) (2.5)."""
    F, Cg = random_F(), random_Cg()
    w, Q = np.linalg.eigh(Cg)
    G = Q @ np.diag(np.sqrt(w)) @ Q.T
    Fe = F @ np.linalg.inv(G)
    Je = np.linalg.det(Fe)
    W0 = (MAT.mu1 / 2 * np.sum(Fe**2) + MAT.mu2 / 2 * np.sum(cf.cof(Fe) ** 2)
          - (MAT.mu1 + 2 * MAT.mu2) * np.log(Je) + MAT.lmbda / 2 * (Je - 1) ** 2)
    assert pw("psi", energy, F, Cg) == pytest.approx(W0 * np.linalg.det(G), rel=1e-12)


def test_plane_strain_is_the_embedded_3d_energy():
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 1, 1)
    F2 = np.array([[1.2, 0.3], [-0.1, 0.9]])
    C2 = np.array([[1.5, 0.2], [0.2, 0.8]])
    F = dolfinx.fem.Constant(mesh, F2)
    Cg = dolfinx.fem.Constant(mesh, C2)
    value = compat.evaluate_expression(MAT.energy_density(F, Cg), np.array([[0.3, 0.3]]),
                                       mesh, [0]).item()
    F3, C3 = np.eye(3), np.eye(3)
    F3[:2, :2], C3[:2, :2] = F2, C2
    d = np.linalg.det(C3)
    J = np.linalg.det(F3)
    H = cf.cof(F3)
    expected = (MAT.mu1 / 2 / np.sqrt(d) * np.trace(F3.T @ F3 @ cf.cof(C3))
                + MAT.mu2 / 2 / np.sqrt(d) * np.trace(H.T @ H @ C3)
                - (MAT.mu1 + 2 * MAT.mu2) * np.sqrt(d) * np.log(J / np.sqrt(d))
                + MAT.lmbda / 2 * np.sqrt(d) * (J / np.sqrt(d) - 1) ** 2)
    assert value == pytest.approx(expected, rel=1e-13)
