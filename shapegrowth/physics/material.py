"""The growth-modulated strain energies psi(F, C_g), written in UFL: the paper's
compressible Mooney-Rivlin (5.1) and the energies elastomers are fitted with (neo-Hookean,
Yeoh, Gent), each with a volumetric part.

psi is the only constitutive input: the stress P, the elasticity tensor and the
derivatives with respect to the growth parameters all come from it through
``ufl.derivative``/``ufl.diff``, and are checked against the paper's closed
forms in ``shapegrowth.closed_forms`` by the tests.

With G = C_g^(1/2) and A = F G^-1 the elastic part of F, psi(F, C_g) = W0(A) det G (2.5):
W0 per unit volume of the grown, stress-free body, so psi is stress-free exactly when
F^T F = C_g.  The paper's W0(A) = mu1/2 |A|^2 + mu2/2 |cof A|^2 - (mu1 + 2 mu2) log J
+ lambda/2 (J - 1)^2.  The others are written on the first invariant of A's isochoric
part, I1b = J^(-2/3) |A|^2, plus U(J):

* neo-Hookean: mu/2 (I1b - 3);
* Yeoh: c10 (I1b - 3) + c20 (I1b - 3)^2 + c30 (I1b - 3)^3;
* Gent: -mu Jm/2 log(1 - (I1b - 3)/Jm) (the chains' limit at I1b - 3 = Jm);
* U(J) (``material.volumetric``): ``quadratic`` kappa/2 (J - 1)^2, ``log`` kappa/2 (log J)^2,
  or ``simo_taylor`` kappa/4 (J^2 - 1 - 2 log J).

* Ogden: sum_p mu_p/alpha_p (lb_1^alpha_p + lb_2^alpha_p + lb_3^alpha_p - 3) over the
  isochoric principal stretches lb_i, the square roots of the eigenvalues of
  J^(-2/3) F C_g^-1 F^T (A A^T, no square root of C_g needed);
* ``kind: energy``: the user's W0(I1, I2, J, I1b, I2b) (config/energies.py), its text compiled
  into UFL through the expression parser (never executed).

Each has the small-strain shear modulus mu (2 c10 for Yeoh, sum mu_p alpha_p / 2 for Ogden)
and bulk modulus kappa.

The eigenvalues of a symmetric 3x3 tensor (Ogden) are the trigonometric roots of its
characteristic polynomial with the deviator's second invariant shifted by ``EIG_SHIFT``: the
roots of x^3 - 3 (p^2 + s) x - det(C - q I) = 0, q = tr C / 3, p^2 = |C - q I|^2 / 6.  Unshifted
they are not differentiable where two coincide (F = I, every uniaxial state) and UFL's
derivatives divide by zero there; shifted, the power sums of the roots up to the third are
exact (so are the stress and the tangent at F = I) and the fourth is off by 36 p^2 s: W is
off by a relative ~s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ufl
from ufl.core.expr import Expr

from .. import compat
from ..config import Config, resolved
from ..config.energies import INVARIANTS, parse_energy, small_strain_moduli

EIG_SHIFT = 1e-11  # s above: the error in W ~s, round-off in the stress ~1e-16/sqrt(s)


class Energy:
    """What every energy derives from its 3D psi(F, C_g)."""

    def psi(self, F: Expr, Cg: Expr) -> Expr:
        raise NotImplementedError

    def psi_plane_strain(self, F2: Expr, Cg2: Expr) -> Expr:
        """psi for a 2D body in plane strain: F and C_g carry 1 in the X3 direction."""
        return self.psi(embed_plane(F2), embed_plane(Cg2))

    def energy_density(self, F: Expr, Cg: Expr) -> Expr:
        """psi in the body's own dimension (3D, or plane strain in 2D)."""
        return self.psi(F, Cg) if F.ufl_shape == (3, 3) else self.psi_plane_strain(F, Cg)

    @property
    def shear(self) -> float:
        """The small-strain shear modulus."""
        raise NotImplementedError

    @property
    def bulk(self) -> float:
        """The modulus of the quadratic volumetric part the mixed formulation splits off."""
        raise NotImplementedError

    def split(self, F: Expr, Cg: Expr) -> tuple[Expr, Expr, Expr]:
        """sqrt(det C_g), J of the elastic part and psi without its volumetric part
        bulk/2 (J - 1)^2 det G (the mixed formulation's)."""
        raise NotImplementedError

    def psi_mixed(self, F: Expr, Cg: Expr, p: Expr, incompressible: bool) -> Expr:
        """The mixed formulation's psi(F, p, C_g): the volumetric part bulk/2 (J - 1)^2
        replaced by p (J - 1) - p^2 / (2 bulk), whose stationary point in p is p =
        bulk (J - 1) and psi again; incompressible, p (J - 1): p the multiplier of J = 1."""
        root, je, rest = self.split(F, Cg)
        constraint = p * (je - 1)
        if not incompressible:
            constraint = constraint - p ** 2 / (2 * self.bulk)
        return rest + root * constraint


@dataclass(frozen=True)
class MooneyRivlin(Energy):
    """Material constants of (5.1); the paper uses mu1 = mu2 = 0.5, lambda = 3."""

    mu1: float = 0.5
    mu2: float = 0.5
    lmbda: float = 3.0

    @property
    def modulus(self) -> float:
        """A stress scale of the material (mu1 + mu2 + lambda): Newton's force scale."""
        return self.mu1 + self.mu2 + self.lmbda

    @property
    def bulk(self) -> float:
        return self.lmbda

    @property
    def shear(self) -> float:
        """The small-strain shear modulus, mu1 + mu2 (the expansion of (5.1) at F = C_g = I:
        lam/2 (tr e)^2 + mu e:e with mu = mu1 + mu2 and lam = lambda + 2 mu2)."""
        return self.mu1 + self.mu2

    def psi(self, F: Expr, Cg: Expr) -> Expr:
        """Energy density (5.1) for 3x3 tensors F (deformation gradient) and C_g."""
        root, je, rest = self.split(F, Cg)
        return rest + self.lmbda / 2 * root * (je - 1) ** 2

    def split(self, F: Expr, Cg: Expr) -> tuple[Expr, Expr, Expr]:
        det_cg = ufl.det(Cg)
        root = ufl.sqrt(det_cg)
        J = ufl.det(F)
        H = ufl.cofac(F)
        je = J / root  # det of the elastic part F G^-1
        return root, je, (self.mu1 / 2 / root * ufl.tr(F.T * F * ufl.cofac(Cg))
                          + self.mu2 / 2 / root * ufl.tr(H.T * H * Cg)
                          - (self.mu1 + 2 * self.mu2) * root * ufl.ln(je))


@dataclass(frozen=True)
class Isochoric(Energy):
    """An energy on the isochoric invariants of A plus a volumetric part U(J):
    ``kind`` neo_hookean (mu), yeoh (c10, c20, c30) or gent (mu, Jm)."""

    kind: str
    kappa: float
    volumetric: str = "quadratic"
    mu: float = 0.0
    c: tuple[float, float, float] = (0.0, 0.0, 0.0)
    Jm: float = 0.0

    @property
    def shear(self) -> float:
        """The small-strain shear modulus."""
        return 2 * self.c[0] if self.kind == "yeoh" else self.mu

    @property
    def modulus(self) -> float:
        """A stress scale of the material (shear + bulk modulus): Newton's force scale."""
        return self.shear + self.kappa

    def deviatoric(self, i1b: Expr) -> Expr:
        """W0's isochoric part as a function of I1b."""
        x = i1b - 3
        if self.kind == "neo_hookean":
            return self.mu / 2 * x
        if self.kind == "yeoh":
            return self.c[0] * x + self.c[1] * x ** 2 + self.c[2] * x ** 3
        if self.kind == "gent":
            return -self.mu * self.Jm / 2 * ufl.ln(1 - x / self.Jm)
        raise ValueError(f"unknown energy {self.kind!r}")

    def volume(self, J: Expr) -> Expr:
        return volume(self.volumetric, self.kappa, J)

    @property
    def bulk(self) -> float:
        return self.kappa

    def psi(self, F: Expr, Cg: Expr) -> Expr:
        """W0(F G^-1) det G for 3x3 tensors F and C_g: |A|^2 = tr(F^T F C_g^-1)."""
        root, je, rest = self.split(F, Cg)
        return rest + root * self.volume(je)

    def split(self, F: Expr, Cg: Expr) -> tuple[Expr, Expr, Expr]:
        root = ufl.sqrt(ufl.det(Cg))
        je = ufl.det(F) / root
        i1 = ufl.tr(F.T * F * ufl.cofac(Cg)) / root ** 2  # cofac(C_g) = det C_g C_g^-1
        return root, je, root * self.deviatoric(je ** (-2.0 / 3.0) * i1)



def volume(kind: str, kappa: float, J: Expr) -> Expr:
    """U(J), zero with zero slope at J = 1, of second derivative kappa there."""
    if kind == "quadratic":
        return kappa / 2 * (J - 1) ** 2
    if kind == "log":
        return kappa / 2 * ufl.ln(J) ** 2
    return kappa / 4 * (J ** 2 - 1 - 2 * ufl.ln(J))


def elastic_invariants(F: Expr, Cg: Expr) -> tuple[Expr, Expr, Expr, Expr]:
    """sqrt(det C_g), the elastic part's J, A A^T = F C_g^-1 F^T and its trace I1."""
    det_cg = ufl.det(Cg)
    root = ufl.sqrt(det_cg)
    b = F * ufl.cofac(Cg) * F.T / det_cg  # cofac(C_g) = det C_g C_g^-1 (C_g symmetric)
    return root, ufl.det(F) / root, b, ufl.tr(b)


def symmetric_eigenvalues(C: Expr) -> tuple[Expr, Expr, Expr]:
    """The eigenvalues of a symmetric 3x3 tensor, shifted as the module says (EIG_SHIFT)."""
    q = ufl.tr(C) / 3
    D = C - q * ufl.Identity(3)
    p2 = ufl.inner(D, D) / 6 + EIG_SHIFT * q ** 2
    p = ufl.sqrt(p2)
    r = ufl.det(D) / (2 * p * p2)
    r = ufl.max_value(ufl.min_value(r, 1.0), -1.0)
    phi = ufl.acos(r) / 3
    first = q + 2 * p * ufl.cos(phi)
    third = q + 2 * p * ufl.cos(phi + 2 * np.pi / 3)
    return first, 3 * q - first - third, third


@dataclass(frozen=True)
class Ogden(Energy):
    """sum_p mu_p/alpha_p (sum_i lb_i^alpha_p - 3) + U(J) over the isochoric stretches."""

    mu_p: tuple[float, ...]
    alpha_p: tuple[float, ...]
    kappa: float
    volumetric: str = "quadratic"

    @property
    def shear(self) -> float:
        return sum(m * a for m, a in zip(self.mu_p, self.alpha_p)) / 2

    @property
    def modulus(self) -> float:
        return self.shear + self.kappa

    @property
    def bulk(self) -> float:
        return self.kappa

    def psi(self, F: Expr, Cg: Expr) -> Expr:
        root, je, rest = self.split(F, Cg)
        return rest + root * volume(self.volumetric, self.kappa, je)

    def split(self, F: Expr, Cg: Expr) -> tuple[Expr, Expr, Expr]:
        root, je, b, _ = elastic_invariants(F, Cg)
        squares = symmetric_eigenvalues(je ** (-2.0 / 3.0) * b)  # lb_i^2
        w = sum(m / a * (sum(c ** (a / 2) for c in squares) - 3)
                for m, a in zip(self.mu_p, self.alpha_p))
        return root, je, root * w


# what material.energy's calls stand for in UFL
UFL_FUNCTIONS = {"sin": ufl.sin, "cos": ufl.cos, "tan": ufl.tan, "exp": ufl.exp,
                 "log": ufl.ln, "sqrt": ufl.sqrt, "abs": abs,
                 "arctan2": compat.atan2}


@dataclass(frozen=True)
class UserEnergy(Energy):
    """``material.energy``: W0 over I1, I2, J, I1b, I2b of the elastic part and named
    numbers ``params``; its small-strain moduli found by config.energies."""

    text: str
    params: tuple[tuple[str, float], ...] = ()

    @property
    def shear(self) -> float:
        return small_strain_moduli(self.text, dict(self.params)).shear

    @property
    def kappa(self) -> float:
        return small_strain_moduli(self.text, dict(self.params)).bulk

    @property
    def modulus(self) -> float:
        moduli = small_strain_moduli(self.text, dict(self.params))
        return moduli.shear + moduli.bulk

    def psi(self, F: Expr, Cg: Expr) -> Expr:
        root, je, b, i1 = elastic_invariants(F, Cg)
        i2 = (i1 ** 2 - ufl.inner(b, b)) / 2  # b symmetric: tr(b b) = b : b
        env: dict[str, object] = dict(self.params)
        env.update(zip(INVARIANTS, (i1, i2, je, je ** (-2.0 / 3.0) * i1,
                                    je ** (-4.0 / 3.0) * i2)))
        expr = parse_energy(self.text, dict(self.params), UFL_FUNCTIONS)
        return root * expr(env)


Material = MooneyRivlin | Isochoric | Ogden | UserEnergy


def material_of(cfg: Config) -> Material:
    """The config's ``material`` as its energy (config.checks resolved its constants)."""
    m = cfg.material
    if m.kind == "mooney_rivlin":  # incompressible: no lmbda (the pressure holds J = 1)
        return MooneyRivlin(resolved(m.mu1), resolved(m.mu2), m.lmbda or 0.0)
    kappa = m.kappa or 0.0  # None where incompressible
    if m.kind == "ogden":
        return Ogden(tuple(resolved(m.mu_p)), tuple(resolved(m.alpha_p)), kappa,
                     resolved(m.volumetric))
    if m.kind == "energy":
        params = cfg.expression_params
        return UserEnergy(resolved(m.energy), tuple(sorted(params.items())))
    return Isochoric(m.kind, kappa, resolved(m.volumetric), mu=m.mu or 0.0,
                     c=(m.c10 or 0.0, m.c20 or 0.0, m.c30 or 0.0), Jm=m.Jm or 0.0)


def embed_plane(A2: Expr) -> Expr:
    """The 3x3 tensor [[A2, 0], [0, 1]] of a 2x2 tensor A2 (plane strain)."""
    return ufl.as_matrix([[A2[0, 0], A2[0, 1], 0], [A2[1, 0], A2[1, 1], 0], [0, 0, 1]])


def deformation_gradient(u: Expr) -> Expr:
    return ufl.Identity(len(u)) + ufl.grad(u)
