"""The state's Newton solver: its PETSc options, the near-nullspace an iterative linear
solver needs, and PETSc's convergence reasons in words."""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from .. import compat
from ..config import Config
from .linear import preset_options


def solver_options(cfg: Config, force_scale: float, linear: str) -> dict[str, object]:
    """PETSc options of the state solver (without a prefix).

    The absolute tolerance is ``solver.atol`` times the body's force scale, so that
    it means the same for a beam of volume 0.002 and a square of area 16: thin bodies
    are soft in bending (a residual of 1e-10 left displacement errors of 1e-6 on the
    beam), while the residual of a body at rest is round-off, ~1e-16 of that scale.
    ``linear``: the linear solver's preset (physics/linear.py), resolved."""
    s = cfg.solver
    opts: dict[str, object] = {
        "snes_type": "newtonls",
        "snes_linesearch_type": s.line_search,
        "snes_max_it": s.max_newton_iterations,
        "snes_rtol": s.rtol,
        "snes_atol": s.atol * force_scale,
        "snes_stol": s.stol,
        "snes_error_if_not_converged": False,
    }
    opts.update(preset_options(linear, "state_"))
    return opts


def rigid_body_modes(V) -> PETSc.NullSpace:
    """Translations and infinitesimal rotations, the near-nullspace for GAMG."""
    gdim = V.mesh.geometry.dim
    index_map, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    n = index_map.size_local
    x = V.tabulate_dof_coordinates()[:n]
    modes = np.zeros((6 if gdim == 3 else 3, n, bs))
    for i in range(gdim):
        modes[i, :, i] = 1.0
    if gdim == 3:
        modes[3, :, 0], modes[3, :, 1] = -x[:, 1], x[:, 0]
        modes[4, :, 0], modes[4, :, 2] = x[:, 2], -x[:, 0]
        modes[5, :, 2], modes[5, :, 1] = x[:, 1], -x[:, 2]
    else:
        modes[2, :, 0], modes[2, :, 1] = -x[:, 1], x[:, 0]
    vecs: list[PETSc.Vec] = []
    for mode in modes:  # Gram-Schmidt with PETSc's (global) products: dolfinx.la's
        vec = compat.index_map_vector(index_map, bs)  # orthonormalize takes
        vec.array[:] = mode.ravel()  # PETSc vectors in 0.5.2, its own in 0.9
        for other in vecs:
            vec.axpy(-vec.dot(other), other)
        vec.normalize()
        vecs.append(vec)
    return PETSc.NullSpace().create(vectors=vecs)


SNES_REASONS = {  # PETSc's SNESConvergedReason
    2: "converged (atol)", 3: "converged (rtol)", 4: "converged (step)", 5: "converged (its)",
    -1: "function domain error", -2: "too many function evaluations",
    -3: "linear solve failed", -4: "NaN residual", -5: "maximum Newton iterations",
    -6: "line search failed", -7: "inner solve failed", -8: "local minimum",
    -9: "diverged (dtol)", -10: "Jacobian domain error", -11: "trust region collapsed",
}
