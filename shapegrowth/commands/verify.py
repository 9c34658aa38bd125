"""``shapegrowth verify RUN_DIR [--refine N]``: a finished run's verification, verified.

A run leads with its best growth grown from rest on its mesh refined ``verify.refine``
times (and, for a section, lifted onto its 3D body there).  Whether that number is itself
converged is a question for the next mesh: this command grows the same growth (growth.npz)
from rest on the run's last mesh refined N times (default: once more than the run did;
nested for simplices, regenerated with every count doubled for hexahedra) and measures it
there, as the run's own verification does.  A section run with ``verify.lift`` (or
``--lift CONFIG_3D``) is lifted as well, onto its 3D body refined N - ``verify.refine``
times more than the run's lift was.

The check (:class:`~shapegrowth.io.records.Reverified`): the finer number must move by
less than a third of the way from the run's number to 1 %, so that no further refinement
is likely to carry it across the scenes' 1 %.  Writes verify.json (the new verification,
the run's number and the check) to ``--out`` (default RUN_DIR/verify-rN), and beside it,
as the check goes, progress.log (each load step, stamped with the time, even with ``-q``).
``--set`` applies to the run's config (and to the 3D config of a lift), e.g.
``solver.linear=mumps_ooc`` for a mesh whose factor does not fit in memory.

``--continued`` makes a check of a mesh too large to grow from rest on (a factorisation of
a million DOFs or more per Newton iteration, and 74-107 iterations from rest: hours): the
growth is grown from rest on the mesh refined N - 1 times (for a section, its 3D body's), and
that equilibrium carried onto the mesh refined N times and solved there at the full growth,
Newton's few iterations from it, its stability assessed where it ends.  The path from rest,
and with it the branch, is then the coarser mesh's; the finer mesh measures the
discretisation.  verify.json says so (``continued_from``), and the log.

A run stopped before its summary.json (in its optimisation, or in its own verification)
is not verified here but finished: ``shapegrowth run CONFIG --out RUN_DIR --resume`` replays
its recorded iterations without a solve and goes on from where it stopped.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from pathlib import Path

from ..config import Config, load
from ..errors import InputError
from ..io import files as io
from ..io.records import Lifted, Reverified, Verified
from ..io.summary import percent
from ..logs import progress_file
from ..optim.lift import lifted_from_rest, lifted_model, verification_model
from ..optim.verification import verified_from_rest, verify
from ..physics.model import ForwardModel
from ..physics.stability import describe, unstable_tag
from .lift import reduced_run, solve_best_growth

log = logging.getLogger(__name__)


def lift_config(cfg: Config, lift_path: str | None, overrides: list[str] | tuple[str, ...],
                refine: int) -> Config | None:
    """The 3D config a section run is lifted onto at ``refine`` (the run's refinement of the
    check), refined as much more than the run's own lift; None for no lift."""
    path = lift_path if lift_path is not None else cfg.verify.lift
    if path is None or path == "none":
        return None
    if not Path(path).is_file():
        raise InputError(f"verify: the 3D config to lift onto, {path}, not found (run from the "
                         "folder the run was made in, or give --lift CONFIG_3D; --lift none "
                         "verifies the section alone)")
    solid = load(path, overrides)
    base = cfg.verify.lift_refine if cfg.verify.lift_refine is not None \
        else solid.verify.refine
    return verification_model(solid, base + refine - cfg.verify.refine, cfg.verify.lift_degree)


def reverify(run_dir: Path, refine: int | None = None, out: Path | None = None,
             overrides: list[str] | tuple[str, ...] = (), lift_path: str | None = None,
             continued: bool = False) -> Reverified:
    """The run's best growth verified on its last mesh refined ``refine`` times (default:
    once more than the run), beside the run's own verified number, written to ``out``
    (default RUN_DIR/verify-rN) (collective).  ``continued``: the model the number is read
    on (the 3D body of a lift) grown from rest on the mesh refined ``refine`` - 1 times and
    continued from there (module doc)."""
    cfg, summary, model = reduced_run(run_dir, solve=False, command="verify",
                                      overrides=overrides)
    if summary.verified is None:
        raise InputError(f"verify: {run_dir} was run with verify.enabled false: it has no "
                         "verified number to check")
    first = summary.verified
    refine = first.refine + 1 if refine is None else refine
    out = run_dir / f"verify-r{refine}" if out is None else out
    solid = lift_config(cfg, lift_path, overrides, refine) if cfg.section.reduced else None
    how = ("grown from rest" if not continued else
           f"grown from rest on the mesh refined {refine - 1} time(s) and continued there")
    with progress_file(out / "progress.log", model.comm):  # its load steps, even with -q
        log.info("verify: %s's best growth on its mesh refined %d time(s), %s%s",
                 cfg.name, refine, how if solid is None else "grown from rest",
                 "" if solid is None else
                 f"; lifted onto {solid.name} (its mesh refined {solid.mesh.refine} time(s)), "
                 + how)
        # a section is a 2D model: grown from rest at any refinement; its 3D body continued
        verified = _verify(model, refine, continued and solid is None)
        if solid is not None:  # the departure compares the section's own equilibrium (s)
            solved = solve_best_growth(model, run_dir, "verify")
            lifted = _lift(model, solid, solved, continued, cfg, lift_path, overrides, refine)
            verified = dataclasses.replace(verified, lifted=lifted)
        # like with like: a lift against the run's lift, the model itself against its own
        if solid is None:
            before = first.relative
        else:
            before = first.lifted.relative if first.lifted is not None else None
            if first.lifted is None:
                log.warning("verify: the run was not lifted (verify.lift unset): the lift has "
                            "no number of the run's to be checked against")
        check = Reverified(before, first.refine, verified)
        io.write_json(out / "verify.json", {"run": str(run_dir),
                                            "verified": verified.to_json(),
                                            "check": check.to_json()})
        _report(check)
        log.info("wrote %s", out / "verify.json")
    return check


def _verify(model: ForwardModel, refine: int, continued: bool) -> Verified:
    """The model's own check: from rest, or ``continued`` from its equilibrium from rest on
    the mesh one refinement coarser."""
    if not continued:
        return verify(model, refine)
    tic = time.perf_counter()
    start, reason = verified_from_rest(model, refine - 1)
    if start is None:  # its wall time the coarser solve's
        return Verified(None, None, refine, 0, time.perf_counter() - tic, False,
                        f"failed: {reason}", continued_from=refine - 1)
    return verify(model, refine, start=start)


def _lift(model: ForwardModel, solid: Config, solved: bool, continued: bool, cfg: Config,
          lift_path: str | None, overrides: list[str] | tuple[str, ...], refine: int
          ) -> Lifted:
    """The lift onto ``solid``: from rest, or ``continued`` from the lift onto the same body's
    mesh one refinement coarser, grown from rest there."""
    if not continued:
        return lifted_model(model, solid, compare=solved)[0]
    tic = time.perf_counter()
    coarse = lift_config(cfg, lift_path, overrides, refine - 1)
    assert coarse is not None  # solid is not None
    start, reason = lifted_from_rest(model, coarse, refine - 1)
    if start is None:  # its wall time the coarser solve's
        return Lifted(None, None, 0, time.perf_counter() - tic, f"failed: {reason}",
                      solid.name, continued_from=refine - 1)
    return lifted_model(model, solid, compare=solved, start=start)[0]


def _report(check: Reverified) -> None:
    v = check.second
    where = (f"lifted to 3D ({v.lifted.config}, {v.lifted.dofs} DOFs)" if v.lifted else
             f"{v.dofs} DOFs")
    if check.second_headline is None:
        log.warning("verify: no equilibrium on the mesh refined %d time(s): %s",
                    v.refine, v.headline_status)
        return
    tag = unstable_tag(v.headline_stability)
    start = v.headline_continued_from
    how = "grown from rest" if start is None else \
        f"continued from its equilibrium from rest on the mesh refined {start} time(s)"
    log.info("verified on the mesh refined %d time(s): shape error %s (%s, %s, "
             "%.1f s%s; surface to surface %s); the run's own, refined %d time(s): %s",
             v.refine, percent(check.second_headline), where, how, v.check_wall_s, tag,
             percent(v.headline_surface), check.first_refine, percent(check.first))
    if v.lifted is not None:
        log.info("the section itself on the mesh refined %d time(s): %s", v.refine,
                 percent(v.relative))
    if check.settled is not None:
        verdict = "settled" if check.settled else "NOT settled"
        log.info("the finer mesh moved it by %s, a third of the way to 1 %% is %s: %s",
                 percent(check.moved), percent(check.allowed), verdict)
    log.info("the finer state's stability: %s", describe(v.headline_stability))
