"""The lift: a reduced model's growth carried onto the 3D body it stands for, grown there
from rest and measured there.  A 2D section model (config/reduction.py) counts only with
this number.

Each node X of the 3D body's growth fields takes the reduced growth at the section point X
stands for: (X1, X3) for the X1-X3 section of a box (the growth extruded along X2), and
(R, Z) = (|(X1, X2)|, X3) for a body of revolution (the growth revolved about X3).  The
growth's eigenvalues keep their meaning (the same three, in the same 3D frame), so nothing
else is converted.  The 3D state is then solved from rest by continuation and the exact
Hausdorff distance to the 3D target measured at its sample points, as :func:`verify` does.

How far the 3D body leaves the reduced model is measured beside it (``departure``): every
node of the 3D body against the position the section's own equilibrium gives it (extruded,
or turned to the node's angle), in the section's plane for a plane model (plane stress lets
the width change freely, and the section does not say by how much) and in full for a body
of revolution (a hoop displacement is already a departure).  Anticlastic bending of a beam
and a disk buckled out of axial symmetry show here, whatever the target.
"""

from __future__ import annotations

import dataclasses
import logging
import time

import numpy as np
from mpi4py import MPI

from .. import compat
from ..config import GEOMETRY_PARAMS, Config, ConfigError
from ..io.records import Lifted
from ..physics.growth import Growth
from ..physics.model import ForwardModel
from ..physics.paths import Continued, equilibrium_from_rest, solve_watched
from ..physics.transfer import interpolate_between_meshes
from .objective import measure_verified

log = logging.getLogger(__name__)


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
    if _constitutive(solid) != _constitutive(reduced):
        problems.append(f"verify.lift: '{solid.name}' has another material than the run "
                        "(give both the same material: a run's --set material.* applies to "
                        "the config it lifts onto too)")
    if set(solid.boundary.clamped) != set(reduced.boundary.clamped):
        problems.append(f"verify.lift: '{solid.name}' has another clamp than the run")
    ours, theirs = reduced.objective, solid.objective
    if (set(theirs.compared), theirs.placement) != (set(ours.compared), ours.placement):
        problems.append(f"verify.lift: '{solid.name}' compares {list(theirs.compared)} "
                        f"({theirs.placement}), the run {list(ours.compared)} "
                        f"({ours.placement}); the lift must measure what the run compared")
    if problems:
        raise ConfigError(problems)


def _constitutive(cfg: Config):
    """The material without its formulation: an incompressible section in plane stress holds
    J = 1 through its third stretch, its 3D body through a pressure (the same material)."""
    return dataclasses.replace(cfg.material, formulation=None)


def lift_growth(reduced: Config, growth: Growth, solid: ForwardModel) -> None:
    """Set ``solid``'s growth to the reduced ``growth`` extruded or revolved (collective)."""
    section = reduced.section
    for source, target in zip(growth.fields, solid.growth.fields):
        interpolate_between_meshes(source, target, section.coordinates_of)


def verification_model(solid_cfg: Config, refine: int | None = None,
                       degree: int | None = None) -> Config:
    """The 3D config's own verification model: its finest level's mesh refined
    ``verify.refine`` more times (or ``refine``, the reduced config's ``verify.lift_refine``),
    where a 3D run of it measures its verified error; a lift is measured there, so the two
    numbers compare.  ``degree`` (the reduced config's ``verify.lift_degree``): the growth's
    degree there, where not the 3D config's own.  The lift is measured there with the
    verification's clouds (:func:`lifted_model`), as a 3D run's own verification is."""
    extra = solid_cfg.optimizer.levels[-1] + (solid_cfg.verify.refine if refine is None
                                              else refine)
    growth = solid_cfg.growth if degree is None else dataclasses.replace(solid_cfg.growth,
                                                                         degree=degree)
    return dataclasses.replace(solid_cfg, growth=growth, mesh=dataclasses.replace(
        solid_cfg.mesh, refine=solid_cfg.mesh.refine + extra))


def lift(model: ForwardModel, solid_cfg: Config) -> Lifted:
    """The growth ``model`` (a 2D section model) is in equilibrium with, on the 3D body of
    ``solid_cfg``, solved from rest and measured (collective)."""
    return lifted_model(model, solid_cfg)[0]


def lifted_model(model: ForwardModel, solid_cfg: Config, compare: bool = True,
                 start: Continued | None = None) -> tuple[Lifted, ForwardModel]:
    """:func:`lift`, and the 3D model it solved; ``compare``: measure the departure from
    ``model``'s state (False where that state is not an equilibrium); ``start``: solve it
    at the full growth from a coarser mesh's equilibrium of the same body
    (:func:`lifted_from_rest`; its wall time counted in the lift's), not from rest."""
    check_liftable(model.cfg, solid_cfg)
    tic = time.perf_counter() - (0.0 if start is None else start.seconds)
    solid = lifted_at_rest(model, solid_cfg)
    if start is not None:
        solid.state.carry(start.displacement)
    report, stability, _ = solve_watched(solid.state, lift_branch(model.cfg, solid_cfg))
    dofs = compat.global_size(solid.state.V)
    continued = None if start is None else start.refine
    if not report.converged:
        log.warning("lift: no equilibrium of the 3D body %s: %s",
                    "from rest" if start is None else "near the coarser one", report.reason)
        return Lifted(None, None, dofs, time.perf_counter() - tic, f"failed: {report.reason}",
                      solid_cfg.name, stability=stability, continued_from=continued), solid
    measured = measure_verified(solid_cfg, solid.state)
    size = measured.target_size
    leaves = departure(model, solid) if compare else None
    return Lifted(measured.hausdorff, measured.relative, dofs, time.perf_counter() - tic,
                  "solved", solid_cfg.name,
                  None if leaves is None or size <= 0 else leaves / size, stability,
                  measured.surface, continued), solid


def lifted_at_rest(model: ForwardModel, solid_cfg: Config) -> ForwardModel:
    """The 3D body of ``solid_cfg`` at rest, given the growth of the section ``model``."""
    solid = ForwardModel.build(solid_cfg, model.comm)
    lift_growth(model.cfg, model.state.applied, solid)
    return solid


def lift_branch(reduced: Config, solid: Config) -> str:
    """The branch a lift follows: switch where the reduced run's config or the 3D config asks
    for it."""
    return "switch" if "switch" in (reduced.solver.branch, solid.solver.branch) else "follow"


def lifted_from_rest(model: ForwardModel, solid_cfg: Config, refine: int
                     ) -> tuple[Continued | None, str]:
    """The lift onto ``solid_cfg`` (the check's refinement ``refine``), grown from rest: the
    start of a lift continued onto that body's finer mesh; None and the reason where no
    equilibrium was found (collective)."""
    start, report = equilibrium_from_rest(lambda: lifted_at_rest(model, solid_cfg).state,
                                          refine, lift_branch(model.cfg, solid_cfg))
    if start is None:
        return None, (f"the 3D body from rest on the check's mesh refined {refine} "
                      f"time(s): {report.reason}")
    return start, "solved"


def departure(model: ForwardModel, solid: ForwardModel) -> float | None:
    """The largest distance between a node of the 3D body ``solid`` (in equilibrium) and the
    position the section ``model``'s equilibrium gives it: in the section's plane for a plane
    model, in full for a body of revolution; None where no node lies on the section
    (collective)."""
    section = model.cfg.section
    V = solid.state.V
    n = V.dofmap.index_map.size_local
    mine = V.tabulate_dof_coordinates()[:n]
    everyone = solid.comm.allgather(mine)
    offset = sum(len(c) for c in everyone[:solid.comm.rank])
    points = np.concatenate(everyone)
    on_section = np.zeros((len(points), 3))
    on_section[:, :2] = section.coordinates_of(points)
    u_section = compat.evaluate_at_points(model.state.u, on_section)[offset:offset + n]
    predicted = section.deformed_points(mine, u_section)
    actual = mine + solid.state.u.x.array[:3 * n].reshape(n, 3)
    gap = actual - predicted
    if not section.axisymmetric:  # the width is free in plane stress, held in plane strain
        gap[:, section.out_of_plane] = 0.0
    norms = np.linalg.norm(gap, axis=1)
    norms = norms[~np.isnan(norms)]  # nodes just outside the section's polygon
    local = float(norms.max()) if len(norms) else -1.0
    largest = solid.comm.allreduce(local, op=MPI.MAX)
    return None if largest < 0 else largest

