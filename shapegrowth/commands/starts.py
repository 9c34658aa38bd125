"""``growth.start``: where a model's growth starts when it is not the config's own (given or
the target's metric, physics/growth.py): a finished run's best growth, on the same body
(``run``) or lifted from its 2D section (``lifted``).  Used by ``run`` (its first level)
and ``solve``."""

from __future__ import annotations

import logging
from pathlib import Path

from ..config import Config, resolved
from ..errors import InputError
from ..io import files as io
from ..optim.lift import check_liftable, lift_growth
from ..physics.model import ForwardModel

log = logging.getLogger(__name__)


def start_growth(model: ForwardModel, cfg: Config) -> None:
    """Set ``model``'s growth as ``cfg.growth.start`` asks, where that is a finished run."""
    if cfg.growth.start == "lifted":
        start_lifted(model, Path(resolved(cfg.growth.from_run)))
    elif cfg.growth.start == "run":
        start_from_run(model, Path(resolved(cfg.growth.from_run)))


def start_lifted(model: ForwardModel, run_dir: Path) -> None:
    """growth.start: lifted: the 2D section run's best growth, extruded or revolved onto
    ``model``'s 3D body (its initial growth and design)."""
    from .lift import reduced_run

    reduced_cfg, summary, reduced = reduced_run(run_dir, solve=False)
    check_liftable(reduced_cfg, model.cfg)
    lift_growth(reduced_cfg, reduced.state.applied, model)
    log.info("growth.start: lifted from %s (its verified error %s)", run_dir,
             f"{100 * summary.verified.relative:.3g} %" if summary.verified and
             summary.verified.relative is not None else "not measured")


def start_from_run(model: ForwardModel, run_dir: Path) -> None:
    """growth.start: run: the best growth of a finished run on the same mesh, field by field
    (fields it lacks, such as a fixed frame's angles, keep their initial values)."""
    applied = model.state.applied
    try:
        names = io.read_growth(run_dir / "growth.npz", applied, partial=True)
    except ValueError as err:
        raise InputError(f"growth.from_run: {err}; start: run needs the same body and the "
                         "mesh of this run's first level") from None
    model.growth.assign(applied.values())
    log.info("growth.start: %s from %s", ", ".join(names), run_dir)
