"""Complexity functionals of Sect. 2.4, with the identity as target (the paper's
"such target may well be the identity"), as UFL forms of the growth fields.

With C_g = sum_i lambda_i v_i (x) v_i (orthonormal v_i), G = C_g^(1/2) and N the dimension:

* ``C1``    (2.14): a1 int |C_g - I|^2               = a1 int sum_i (lambda_i - 1)^2
* ``C2``    (2.15): a1 int |C_g / det^(1/N) - I|^2   = a1 int sum_i (lambda_i / P^(1/N) - 1)^2
* ``C1bar``:        a1 int dist(G, SO(N))^2          = a1 int sum_i (sqrt(lambda_i) - 1)^2
* ``C2bar``:        a1 int dist(G / det G^(1/N), SO(N))^2
                    = a1 int sum_i (sqrt(lambda_i) / P^(1/2N) - 1)^2
  (P = prod_i lambda_i; the distance to SO(N) of a symmetric positive definite
  matrix is that of its eigenvalues to 1), each plus the gradient penalty
  a2 int |grad C_g|^2 (C1, C2, none) or a2 int |grad G|^2 (C1bar, C2bar).
"""

from __future__ import annotations

import ufl

from ..config import ComplexityConfig
from ..physics.growth import Growth


def complexity_density(cfg: ComplexityConfig, growth: Growth) -> ufl.core.expr.Expr | None:
    """The integrand, or None when every weight is zero."""
    lams = growth.eigenvalue_exprs()
    n = len(lams)
    product = lams[0]
    for lam in lams[1:]:
        product = product * lam
    roots = [ufl.sqrt(lam) for lam in lams]
    terms = {
        "C1": lambda: sum((lam - 1) ** 2 for lam in lams),
        "C2": lambda: sum((lam / product ** (1.0 / n) - 1) ** 2 for lam in lams),
        "C1bar": lambda: sum((s - 1) ** 2 for s in roots),
        "C2bar": lambda: sum((s / product ** (0.5 / n) - 1) ** 2 for s in roots),
    }
    density = 0
    if cfg.kind != "none" and cfg.weight > 0:
        density = cfg.weight * terms[cfg.kind]()
    if cfg.gradient_weight > 0:
        if cfg.kind.endswith("bar"):
            vs = growth.vectors()
            tensor = sum(s * ufl.outer(v, v) for s, v in zip(roots, vs))
        else:
            tensor = growth.tensor()
        grad = ufl.grad(tensor)
        density = density + cfg.gradient_weight * ufl.inner(grad, grad)
    return None if isinstance(density, int) else density
