"""The lift: a reduced model's growth carried onto the 3D body it stands for, grown there
from rest and measured there.  A 2D section model (config/reduction.py) counts only with
this number.

Each node X of the 3D body's growth fields takes the reduced growth at the section point X
stands for: (X1, X3) for the X1-X3 section of a box (the growth extruded along X2), and
(R, Z) = (|(X1, X2)|, X3) for a body of revolution (the growth revolved about X3).  The
growth's eigenvalues keep their meaning (the same three, in the same 3D frame), so nothing
else is converted.  The 3D state is then solved from rest by continuation and the exact
Hausdorff distance to the 3D target measured at its sample points, as :func:`verify` does.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from dataclasses import dataclass

from .. import compat
from ..config import GEOMETRY_PARAMS, Config, ConfigError
from ..physics.growth import Growth
from ..physics.model import ForwardModel
from ..physics.transfer import interpolate_between_meshes
from .objective import Objective

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Lifted:
    """summary.json's ``lifted``: the reduced growth on the 3D body, grown from rest."""

    hausdorff: float | None  # None where no equilibrium was found from rest
    relative: float | None  # hausdorff / the 3D target's size
    dofs: int  # state DOFs of the 3D model
    wall_s: float
    status: str  # "solved", or "failed: <reason>"
    config: str  # the 3D config's name


def check_liftable(reduced: Config, solid: Config) -> None:
    """The 3D config must describe the body the reduced model is a section of: the same
    geometry, frame and target, in 3D (one ConfigError listing every difference)."""
    problems = []
    if solid.model.dim != 3:
        problems.append("verify.lift: the config to lift to must be 3D (model.dim: 3)")
    if not reduced.section.reduced:
        problems.append("verify.lift: lifts a 2D section model (model.dim: 2 of a box, "
                        "annulus or cylinder_shell)")
    if solid.geometry.kind != reduced.geometry.kind or any(
            getattr(solid.geometry, k) != getattr(reduced.geometry, k)
            for k in GEOMETRY_PARAMS[reduced.geometry.kind]):
        problems.append(f"verify.lift: '{solid.name}' has another geometry than the run "
                        f"({solid.geometry} against {reduced.geometry}); lift onto the body "
                        "the section stands for")
    if solid.growth.frame != reduced.growth.frame:
        problems.append(f"verify.lift: '{solid.name}' has growth.frame {solid.growth.frame}, "
                        f"the run {reduced.growth.frame}; the eigenvalues must mean the same")
    if solid.target != reduced.target:
        problems.append(f"verify.lift: '{solid.name}' has another target than the run")
    if solid.material != reduced.material:
        problems.append(f"verify.lift: '{solid.name}' has another material than the run")
    if solid.boundary != reduced.boundary:
        problems.append(f"verify.lift: '{solid.name}' has another clamp than the run")
    if problems:
        raise ConfigError(problems)


def lift_growth(reduced: Config, growth: Growth, solid: ForwardModel) -> None:
    """Set ``solid``'s growth to the reduced ``growth`` extruded or revolved (collective)."""
    section = reduced.section
    for source, target in zip(growth.fields, solid.growth.fields):
        interpolate_between_meshes(source, target, section.coordinates_of)


def verification_model(solid_cfg: Config) -> Config:
    """The 3D config's own verification model: its finest level's mesh refined
    ``verify.refine`` more times, where a 3D run of it measures its verified error; a lift
    is measured there, so the two numbers compare."""
    extra = solid_cfg.optimizer.levels[-1] + solid_cfg.verify.refine
    return dataclasses.replace(solid_cfg, mesh=dataclasses.replace(
        solid_cfg.mesh, refine=solid_cfg.mesh.refine + extra))


def lift(model: ForwardModel, solid_cfg: Config) -> Lifted:
    """The growth ``model`` (a 2D section model) is in equilibrium with, on the 3D body of
    ``solid_cfg``, solved from rest and measured (collective)."""
    return lifted_model(model, solid_cfg)[0]


def lifted_model(model: ForwardModel, solid_cfg: Config) -> tuple[Lifted, ForwardModel]:
    """:func:`lift`, and the 3D model it solved."""
    check_liftable(model.cfg, solid_cfg)
    tic = time.perf_counter()
    solid = ForwardModel.build(solid_cfg, model.comm)
    lift_growth(model.cfg, model.state.applied, solid)
    report = solid.state.solve()
    dofs = compat.global_size(solid.state.V)
    if not report.converged:
        log.warning("lift: no equilibrium of the 3D body from rest: %s", report.reason)
        return Lifted(None, None, dofs, time.perf_counter() - tic, f"failed: {report.reason}",
                      solid_cfg.name), solid
    objective = Objective(solid_cfg, solid.state)
    hausdorff = objective.exact_hausdorff()
    relative = hausdorff / objective.target_size if objective.target_size > 0 else math.inf
    return Lifted(hausdorff, relative, dofs, time.perf_counter() - tic, "solved",
                  solid_cfg.name), solid
