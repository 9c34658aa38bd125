"""The closing lines of ``shapegrowth run``: the verified number first, the self-reported
one labelled, and the warnings a run's numbers call for (a verified error far above the
run's own, a 3D body that leaves its section, an unstable state, a budget that ended a run
still improving)."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ..io.records import Verified
from ..io.summary import RunSummary
from ..optim.driver import window_progress
from ..optim.interface import Record
from ..optim.verification import TOLERATED, likely_cause
from ..physics.stability import unstable_tag
from ..status import Outcome

if TYPE_CHECKING:
    from .run import Settled

log = logging.getLogger(__name__)


def report_run(summary: RunSummary, settled: Settled, out: Path,
               history: Sequence[Record] = (), window: int = 20) -> None:
    """The closing lines: the verified number first, the self-reported one labelled."""
    size, from_rest = settled.size, settled.from_rest
    rel = settled.hausdorff / size
    if from_rest and settled.branch_changed:
        log.warning("the best growth applied from rest reaches another equilibrium: Hausdorff "
                    "%.4g (%.3g %%) against the optimiser's %.4g: the shape depends on the "
                    "growth path (hausdorff_from_rest in summary.json)", from_rest.hausdorff,
                    100 * from_rest.hausdorff / size, settled.hausdorff)
    _report_verified(summary.verified, rel)
    verified = summary.verified
    for what, stability in (("the optimum on the run's mesh", summary.stability),
                            ("the verified state", verified.stability if verified else None),
                            ("the lifted 3D state", verified.lifted.stability
                             if verified and verified.lifted else None)):
        if stability is not None and not stability.stable:
            log.warning("%s is unstable: %d negative eigenvalue(s) of the tangent, the lowest "
                        "%.4g (summary.json stability; the mode in fields.xdmf)", what,
                        stability.negative, stability.lowest[0])
    log.info("%s after %d iterations: %s; self-reported %.3g %% (own mesh, the optimiser's "
             "path); rho_H %.4g -> %.4g", summary.status, summary.iterations,
             verified_text(summary.verified), 100 * rel, summary.rho_H_initial or float("nan"),
             summary.rho_H_final or float("nan"))
    if summary.status == Outcome.max_iterations():
        report_budget(history, window)
    written = [name for name in ("summary.json", "history.csv", "history.png", "shape.png",
                                 "fields.xdmf") if (out / name).exists()]
    log.info("results in %s: %s", out, ", ".join(written))
    if "fields.xdmf" in written:
        log.info("view: paraview %s, Filters > Warp By Vector (displacement), colour by "
                 "lambda_hat_1", out / "fields.xdmf")


def report_budget(history: Sequence[Record], window: int) -> None:
    """Where the budget, not the stopping test, ended a run that was still improving: the
    last stage's J over the stopping test's window (a quarter arc's 100 iterations end at
    0.37 % verified, its floor 0.076 % after 396: docs/VERIFICATION.md)."""
    if not history:
        return
    # the last stage's J only: a new level or alpha changes what J measures
    last = [r.objective for r in history
            if (r.level, r.alpha) == (history[-1].level, history[-1].alpha)]
    fall = window_progress(last, window)
    if fall is not None and fall > 1e-3:
        log.warning("the iteration budget ended a run still improving (its best J fell from "
                    "%.4g to %.4g over its last %d iterations): optimizer.max_iterations "
                    "larger goes on towards the mesh's floor", min(last[:-window]), min(last),
                    window)


def verified_text(verified: Verified | None) -> str:
    if verified is None:
        return "not verified (verify.enabled: false)"
    times = "once" if verified.refine == 1 else f"{verified.refine} times"
    chosen = ("" if verified.iteration is None else
              f"; iteration {verified.iteration}'s growth, the lowest verified along the run")
    refined = (f"verification {verified.status}" if verified.relative is None else
               f"verified shape error {100 * verified.relative:.3g} % (mesh refined {times}, "
               f"grown from rest{unstable_tag(verified.stability)}{_surface(verified.surface)}"
               f"{chosen})")
    lifted = verified.lifted
    if lifted is None:
        return refined
    if lifted.relative is None:
        return f"lift to 3D {lifted.status}; the reduced model's {refined}"
    return (f"lifted to 3D: shape error {100 * lifted.relative:.3g} % ({lifted.config}, "
            f"{lifted.dofs} DOFs, grown from rest{unstable_tag(lifted.stability)}"
            f"{_surface(lifted.surface)}); the reduced model's {refined}")


def _surface(relative: float | None) -> str:
    """The boundaries' distance beside a sampled number, where it was measured."""
    return "" if relative is None else f"; surface to surface {100 * relative:.3g} %"


def _report_verified(verified: Verified | None, own_relative: float) -> None:
    """The warning of a run whose verified error exceeds its own by more than a factor 2."""
    if verified is None:
        return
    lifted = verified.lifted
    if lifted is not None and lifted.relative is not None and verified.relative is not None \
            and lifted.relative > TOLERATED * max(verified.relative, own_relative):
        log.warning("the 3D body does not follow the reduced model: lifted %.3g %% against the "
                    "reduced model's %.3g %% (verified): what the reduction leaves out matters "
                    "here (anticlastic bending, the width's own stretch, buckling out of "
                    "symmetry); continue in 3D from this growth", 100 * lifted.relative,
                    100 * verified.relative)
    cause = likely_cause(own_relative, verified)
    if cause is None:
        return
    shown = (f"{100 * verified.relative:.3g} %, {verified.relative / own_relative:.1f} times"
             if verified.relative is not None and own_relative > 0 else verified.status)
    if cause == "branch":
        why = ("likely the branch: the growth grown from rest takes another equilibrium than "
               "the optimiser's path (hausdorff_from_rest in summary.json)")
    else:
        why = ("likely the mesh: the run's mesh does not resolve what its optimum leans on "
               "(refine mesh.size, grade the mesh towards the clamp, or lengthen "
               "growth.filter_length)")
    log.warning("the verified shape error (%s the run's own %.3g %%) is not the run's: %s",
                shown, 100 * own_relative, why)
