"""The verified shape error: a growth judged on a refined model, grown from rest.

A run's own number is measured on the mesh it optimised on, at the equilibrium its warm
starts followed.  The body a user grows has neither: it starts at rest and is a continuum.
:func:`verify` carries the growth the body was given (the filtered fields lambda_hat,
theta_hat) onto the run's mesh refined ``refine`` times - nested, so a Lagrange field of
the growth's degree carries over exactly - solves the state there from rest by
continuation (its path watched for stability, and left for a stable branch where
``solver.branch`` is switch), and measures the exact Hausdorff distance to the target at the refined
model's sample points.  That is the number a run leads with (summary.json ``verified``).

Where the verified error exceeds the run's own by more than :data:`TOLERATED`, the likely
cause is named (:func:`likely_cause`): the *branch* when the growth solved from rest on the
run's own mesh already reaches another equilibrium than the optimiser's path, else the
*mesh* (the run's mesh does not resolve what its optimum leans on).

Along a run (``verify.every``) :class:`VerifyEvery` makes the same check every N-th
iteration, into verified.csv (io/along.py); with ``verify.best: verified`` it keeps the
design of the lowest verified number so far (:class:`Candidate`), for the run to end on: a
replayed check's number is read back from verified.csv and its design from the replay, its
full verification made again only if it wins.  The records it makes (:class:`Verified`,
:class:`Reverified`) are io/records.py's.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import compat
from ..config import Config
from ..io.along import Check, append_check, read_checks
from ..io.records import Verified
from ..physics.model import ForwardModel
from ..physics.paths import Continued, equilibrium_from_rest, solve_watched
from ..physics.state import SolveReport
from ..physics.transfer import interpolate_between_meshes
from ..timing import Timer
from .interface import Callback, Step
from .objective import measure_verified

log = logging.getLogger(__name__)

TOLERATED = 2.0  # verified / self beyond which a run warns


def refined_config(cfg: Config, refine: int) -> Config:
    """``cfg`` on its mesh refined ``refine`` more times (nested in the run's mesh).  The
    model solved there is the run's own, its clouds included (they set where an
    equilibrium's det F is checked); :func:`verify` measures it with the verification's
    clouds (:func:`~shapegrowth.optim.objective.verification_clouds`)."""
    return dataclasses.replace(cfg, mesh=dataclasses.replace(
        cfg.mesh, refine=cfg.mesh.refine + refine))


def grown_from_rest(model: ForwardModel, cfg: Config) -> tuple[ForwardModel, SolveReport]:
    """The growth ``model`` is in equilibrium with, carried onto the discretisation of
    ``cfg`` (exactly where its mesh is nested in ``model``'s) and solved there from rest
    (collective): the verification's model, and the study's reference."""
    other = carried_to(model, cfg)
    return other, other.state.solve()


def carried_to(model: ForwardModel, cfg: Config) -> ForwardModel:
    """A model of ``cfg`` at rest, given the growth ``model`` is in equilibrium with."""
    other = ForwardModel.build(cfg, model.comm)
    for source, target in zip(model.state.applied.fields, other.growth.fields):
        interpolate_between_meshes(source, target)
    return other


def verify(model: ForwardModel, refine: int, branch_changed: bool = False,
           start: Continued | None = None) -> Verified:
    """The growth ``model`` is in equilibrium with, on its mesh refined ``refine`` times,
    solved from rest (collective).  ``start``: solved there at the full growth from the
    equilibrium grown from rest on a coarser mesh (:func:`verified_from_rest`;
    ``shapegrowth verify --continued``), that solve's wall time counted in the check's."""
    tic = time.perf_counter() - (0.0 if start is None else start.seconds)
    cfg = refined_config(model.cfg, refine)
    coarser = None if start is None else start.refine
    fine = carried_to(model, cfg)
    if start is not None:
        fine.state.carry(start.displacement)
    report, stability, _ = solve_watched(fine.state, cfg.solver.branch)
    dofs = compat.global_size(fine.state.V)
    if not report.converged:
        log.warning("verification: no equilibrium %s on the refined mesh: %s",
                    "from rest" if coarser is None else "near the coarser one", report.reason)
        return Verified(None, None, refine, dofs, time.perf_counter() - tic, branch_changed,
                        f"failed: {report.reason}", stability=stability,
                        continued_from=coarser)
    measured = measure_verified(cfg, fine.state)
    return Verified(measured.hausdorff, measured.relative, refine, dofs,
                    time.perf_counter() - tic, branch_changed, "solved", stability=stability,
                    surface=measured.surface, continued_from=coarser)


def verified_from_rest(model: ForwardModel, refine: int) -> tuple[Continued | None, str]:
    """The growth ``model`` is in equilibrium with, on its mesh refined ``refine`` times,
    grown from rest: the start of a check continued onto a finer mesh; None and the reason
    where no equilibrium was found (collective)."""
    start, report = equilibrium_from_rest(
        lambda: carried_to(model, refined_config(model.cfg, refine)).state, refine,
        model.cfg.solver.branch)
    if start is None:
        return None, f"from rest on the mesh refined {refine} time(s): {report.reason}"
    return start, "solved"


def branch_changed(from_rest: float | None, own: float, target_size: float) -> bool:
    """Whether the growth solved from rest on the run's own mesh (Hausdorff ``from_rest``)
    reaches another equilibrium than the optimiser's (``own``): more than 5 % apart, and
    more than 1e-3 of the target size.  A failed solve from rest counts as changed."""
    if from_rest is None:
        return True
    return abs(from_rest - own) > max(0.05 * own, 1e-3 * target_size)


def likely_cause(own_relative: float, verified: Verified) -> str | None:
    """None when the verified error is within :data:`TOLERATED` of the run's own, else the
    likely cause: "branch" or "mesh" (module doc)."""
    if verified.relative is None:
        return "branch" if verified.branch_changed else "mesh"
    if verified.relative <= TOLERATED * own_relative:
        return None
    return "branch" if verified.branch_changed else "mesh"


@dataclass(frozen=True)
class Candidate:
    """The lowest verified check of a level so far: its row, this rank's share of its
    design, and its verification (None for a check read back from a resumed run's
    verified.csv: made again if it wins)."""

    check: Check
    design: np.ndarray
    verified: Verified | None

    @property
    def relative(self) -> float:
        return _or_inf(self.check.verified_relative)


class VerifyEvery(Callback):
    """The check every ``every``-th iteration (collective: every rank calls it).
    ``local`` gives this rank's share of a design of the whole body (the driver's
    :class:`GlobalVector`): with it, the lowest verified check's design is kept
    (:attr:`best`)."""

    def __init__(self, model: ForwardModel, refine: int, every: int, size: float,
                 path: Path, timer: Timer, level: int, offset: int, spent: float = 0.0,
                 local: Callable[[np.ndarray], np.ndarray] | None = None):
        self.model, self.refine, self.every, self.size = model, refine, every, size
        self.path, self.timer, self.level, self.offset = path, timer, level, offset
        self.spent = spent  # the checks' seconds before this level
        self.local = local
        self.checks: list[Check] = []
        self.best: Candidate | None = None
        self.last: Candidate | None = None  # the latest check made here (not read back)
        # a resumed run's earlier checks of this level, by iteration (read on every rank)
        self.earlier = {c.iteration: c for c in read_checks(path) if c.level == level} \
            if local is not None else {}

    def evaluated(self, step: Step) -> None:
        if (step.iteration + 1) % self.every:
            return
        if step.replayed:
            earlier = self.earlier.get(self.offset + step.iteration)
            if earlier is not None:
                self._keep(earlier, None, step.x)
            return
        tic = time.perf_counter()
        clock = tic - self.timer.start - self.spent
        verified = verify(self.model, self.refine)
        self.spent += time.perf_counter() - tic
        check = Check(self.level, self.offset + step.iteration, clock,
                      step.record.hausdorff / self.size if self.size > 0 else float("inf"),
                      verified.relative, self.spent)
        self.checks.append(check)
        append_check(self.path, check, self.model.comm)
        self._keep(check, verified, step.x)
        if self.local is not None:
            self.last = Candidate(check, self.local(step.x).copy(), verified)

    def _keep(self, check: Check, verified: Verified | None, x: np.ndarray) -> None:
        """The check's design as the best so far where its verified number is lower (the
        first of equal ones)."""
        if self.local is None or _or_inf(check.verified_relative) == float("inf"):
            return
        if self.best is None or _or_inf(check.verified_relative) < self.best.relative:
            self.best = Candidate(check, self.local(x).copy(), verified)


def _or_inf(relative: float | None) -> float:
    """A verified number, a failed verification counting as infinitely far."""
    return float("inf") if relative is None else relative
