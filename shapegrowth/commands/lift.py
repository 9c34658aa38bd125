"""``shapegrowth lift RUN_DIR --config CONFIG_3D``: a reduced run's best growth on its 3D body.

The run's own config (summary.json) rebuilds its 2D model, its growth.npz sets the growth,
and :func:`shapegrowth.optim.lift.lift` carries it onto the 3D body of CONFIG_3D (extruded
or revolved) on that config's own verification model (its finest level refined
``verify.refine`` times, where its own runs measure their verified error; the run's
``verify.lift_refine`` times where it sets that), solves it from rest and measures it there,
beside how far the 3D body leaves the section's own equilibrium (solved from rest).  Writes
lift.json (the lifted numbers beside the run's verified and self-reported ones) and
fields.xdmf of the 3D body to ``--out`` (default RUN_DIR/lift).
"""

from __future__ import annotations

import logging
from pathlib import Path

from ..config import Config, from_dict
from ..errors import InputError
from ..io import files as io
from ..io.records import Lifted
from ..io.summary import RunSummary, percent
from ..optim.lift import lifted_model, verification_model
from ..optim.verification import refined_config
from ..physics.model import ForwardModel
from ..physics.stability import describe, unstable_tag

log = logging.getLogger(__name__)


def reduced_run(run_dir: Path, solve: bool = True, command: str = "lift",
                overrides: list[str] | tuple[str, ...] = ()
                ) -> tuple[Config, RunSummary, ForwardModel]:
    """The run's config (``overrides`` applied), summary and model (a 2D one for the lift)
    at its best growth, in equilibrium from rest where that solve converges (``solve``;
    else at rest) (collective); ``command`` names the caller in errors."""
    if not (run_dir / "summary.json").is_file() and (run_dir / "checkpoint.h5").is_file():
        # stopped before its summary (in the optimisation or in its own verification): the
        # resume replays every recorded iteration without a solve and goes on from there
        raise InputError(f"{command}: {run_dir} has no summary.json: the run did not finish; "
                         f"finish it with `shapegrowth run CONFIG --out {run_dir} --resume` "
                         "(with the run's --set), then try again")
    for name in ("summary.json", "growth.npz"):
        if not (run_dir / name).is_file():
            kind = " of a 2D section model" if command == "lift" else ""
            raise InputError(f"{command}: {run_dir / name} not found (RUN_DIR is the folder of "
                             f"a finished `shapegrowth run`{kind})")
    summary = RunSummary.from_json(io.read_json(run_dir / "summary.json"))
    # the mesh of the run's last level
    base = from_dict(summary.config, overrides)
    cfg = refined_config(base, io.growth_refinements(run_dir / "growth.npz") - base.mesh.refine)
    model = ForwardModel.build(cfg)
    try:
        io.read_growth(run_dir / "growth.npz", model.state.applied)
    except ValueError as err:
        raise InputError(f"{command}: {err}") from None
    model.growth.assign(model.state.applied.values())
    if solve:  # a 2D solve: seconds
        solve_best_growth(model, run_dir, command)
    return cfg, summary, model


def solve_best_growth(model: ForwardModel, run_dir: Path, command: str) -> bool:
    """The model in equilibrium at the run's best growth from rest; where that solve does
    not converge, back at rest with the run's growth (said in one line) (collective)."""
    report = model.state.solve()
    if not report.converged:
        log.warning("%s: the best growth from rest: %s", command, report.reason)
        model.state.reset()
        io.read_growth(run_dir / "growth.npz", model.state.applied)
    return report.converged


def lift_run(run_dir: Path, solid_cfg: Config, out: Path) -> Lifted:
    """The run's best growth on the 3D body of ``solid_cfg``, on that config's own
    verification model (its finest level refined ``verify.refine`` times)."""
    cfg, summary, model = reduced_run(run_dir)
    lifted, solid = lifted_model(model, verification_model(solid_cfg, cfg.verify.lift_refine,
                                                           cfg.verify.lift_degree),
                                 compare=bool(model.state.u.x.array.any()))
    io.write_fields(out / "fields.xdmf", solid.state.u, solid.state.applied,
                    extra=[io.deformation_field(solid.state.u)])
    verified = summary.verified
    io.write_json(out / "lift.json", {
        "run": str(run_dir),
        "lifted": lifted.to_json(),
        "reduced_verified": verified.relative if verified else None,
        "reduced_self": summary.relative_error})
    if lifted.relative is None:
        log.warning("lift: %s", lifted.status)
    else:
        log.info("lifted to 3D: shape error %.3g %% (%s, %d DOFs, grown from rest, %.1f s%s; "
                 "surface to surface %s); the reduced model: verified %s, self-reported %s; "
                 "the 3D body leaves the section's shape by up to %s of the target size",
                 100 * lifted.relative, solid_cfg.name, lifted.dofs, lifted.wall_s,
                 unstable_tag(lifted.stability),
                 percent(lifted.surface),
                 percent(verified.relative if verified else None, "not verified"),
                 percent(summary.relative_error), percent(lifted.departure))
    log.info("the 3D body's stability: %s", describe(lifted.stability))
    log.info("wrote %s", out / "lift.json")
    return lifted
