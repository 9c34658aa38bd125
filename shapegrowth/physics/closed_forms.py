"""The paper's closed forms in plain numpy, used to check what UFL derives.

* (5.9): the first Piola-Kirchhoff stress P(F, C_g);
* Sect. 5.1.3: the elasticity tensor d2psi/dFdF, written with the tensor cross
  product; read with the factor (det C_g)^(-1/2) in d2W/dFdF and d2W/dHdH (the
  print drops it there while keeping it in dW/dH; without it P would not be the
  derivative of psi);
* (5.13): T = d(P : grad p)/dC_g, so that d(P : grad p)/dlambda_i = v_i . T v_i;
* (5.5): the eigenvectors from the Rodrigues angles.  The printed third
  component of v1 repeats the first component of v3; the Rodrigues formula
  (5.3)-(5.4) gives -sin t2 (sin t3 sin t1 + cos t2 cos t1 (cos t3 - 1)), which
  is what :func:`rodrigues_vectors` returns (the printed one is not orthogonal
  to v2).
"""

from __future__ import annotations

import numpy as np

ArrayOrFloat = float | np.ndarray  # a value, or one per point

EPS = np.zeros((3, 3, 3))
EPS[0, 1, 2] = EPS[1, 2, 0] = EPS[2, 0, 1] = 1.0
EPS[0, 2, 1] = EPS[2, 1, 0] = EPS[1, 0, 2] = -1.0


def cross(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Tensor cross product (A x B)_iI = e_ijk e_IJK A_jJ B_kK."""
    return np.einsum("ijk,IJK,jJ,kK->iI", EPS, EPS, A, B)


def cof(A: np.ndarray) -> np.ndarray:
    """Cofactor, cof A = (A x A) / 2 = det(A) A^-T."""
    return 0.5 * cross(A, A)


def stress(F: np.ndarray, Cg: np.ndarray, mu1: float, mu2: float, lmbda: float) -> np.ndarray:
    """(5.9)."""
    d = np.linalg.det(Cg)
    H, J = cof(F), np.linalg.det(F)
    dJ = -(mu1 + 2 * mu2) * np.sqrt(d) / J + lmbda * (J / np.sqrt(d) - 1)
    return (mu1 / np.sqrt(d) * F @ cof(Cg) + mu2 / np.sqrt(d) * cross(H @ Cg, F) + dJ * H)


def elasticity(F: np.ndarray, Cg: np.ndarray, mu1: float, mu2: float,
               lmbda: float) -> np.ndarray:
    """d2psi/dFdF as C[i, I, j, J] from the polyconvex split of Sect. 5.1.3."""
    d = np.linalg.det(Cg)
    H, J = cof(F), np.linalg.det(F)
    delta = np.eye(3)
    d2_FF = mu1 / np.sqrt(d) * np.einsum("ij,IJ->iIjJ", delta, cof(Cg))
    d2_HH = mu2 / np.sqrt(d) * np.einsum("ij,IJ->iIjJ", delta, Cg)
    d2_JJ = (mu1 + 2 * mu2) * np.sqrt(d) / J**2 + lmbda / np.sqrt(d)
    d_J = -(mu1 + 2 * mu2) * np.sqrt(d) / J + lmbda * (J / np.sqrt(d) - 1)
    d_H = mu2 / np.sqrt(d) * H @ Cg
    sigma = d_H + d_J * F
    F_HH_F = np.einsum("piq,PIQ,qQ,pPtT,tju,TJU,uU->iIjJ", EPS, EPS, F, d2_HH, EPS, EPS, F)
    geometric = np.einsum("pij,PIJ,pP->iIjJ", EPS, EPS, sigma)
    return d2_FF + F_HH_F + d2_JJ * np.einsum("iI,jJ->iIjJ", H, H) + geometric


def growth_sensitivity(F: np.ndarray, Cg: np.ndarray, grad_p: np.ndarray, mu1: float,
                       mu2: float, lmbda: float) -> np.ndarray:
    """T of (5.13): d(P(F, C_g) : grad p)/dC_g."""
    d = np.linalg.det(Cg)
    H, J = cof(F), np.linalg.det(F)
    cof_cg = cof(Cg)
    F_x_gp = cross(F, grad_p)
    return (-mu1 / 2 * d**-1.5 * np.trace((F @ cof_cg).T @ grad_p) * cof_cg
            + mu1 / np.sqrt(d) * cross(Cg, F.T @ grad_p)
            - mu2 / 2 * d**-1.5 * np.trace((H @ Cg).T @ F_x_gp) * cof_cg
            + mu2 / np.sqrt(d) * H.T @ F_x_gp
            - np.trace(H.T @ grad_p) * ((mu1 + 2 * mu2) / (2 * J * np.sqrt(d))
                                        + lmbda * J / (2 * d**1.5)) * cof_cg)


def rodrigues_vectors(t1: ArrayOrFloat, t2: ArrayOrFloat, t3: ArrayOrFloat) -> np.ndarray:
    """(5.5) with v1[2] corrected: rows are v1, v2, v3."""
    c1, s1, c2, s2, c3, s3 = np.cos(t1), np.sin(t1), np.cos(t2), np.sin(t2), np.cos(t3), np.sin(t3)
    v1 = [(c3 - 1) * (c2**2 + s2**2 * s1**2) + 1,
          c2 * s3 - c1 * s2**2 * s1 * (c3 - 1),
          -s2 * (s3 * s1 + c2 * c1 * (c3 - 1))]
    v2 = [-c2 * s3 - c1 * s2**2 * s1 * (c3 - 1),
          (c3 - 1) * (c2**2 + c1**2 * s2**2) + 1,
          s2 * (s3 * c1 - c2 * s1 * (c3 - 1))]
    v3 = [s2 * (s3 * s1 - c2 * c1 * (c3 - 1)),
          -s2 * (s3 * c1 + c2 * s1 * (c3 - 1)),
          (c3 - 1) * (s2**2 * s1**2 + c1**2 * s2**2) + 1]
    return np.array([v1, v2, v3])
