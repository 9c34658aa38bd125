"""verified.csv: the verified shape error along a run (``verify.every``).

Every ``every``-th iteration the design just evaluated is grown from rest on the run's mesh
refined ``verify.refine`` times and measured there, as the run's final verification does
(:func:`shapegrowth.optim.refined.verify`); one row per check: the level, the iteration,
the run's clock at that iteration without the checks themselves (what a run without them
would have taken to get there), the self-reported and the verified shape error, and the
checks' own seconds so far.  ``shapegrowth bench --runs`` reads the time to a verified
1 % and 0.3 % from it.  A resumed run appends; replayed iterations are not checked again.

With ``verify.best: verified`` the checks also keep the design of the lowest verified
number so far (:class:`Candidate`), for the run to end on: a replayed check's number is read
back from verified.csv and its design from the replay, its full verification made again
only if it wins.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mpi4py import MPI

from ..optim.interface import Callback, Step
from ..optim.refined import Verified, verify
from ..physics.model import ForwardModel
from ..timing import Timer

COLUMNS = ("level", "iteration", "seconds", "self_relative", "verified_relative",
           "verification_seconds")


@dataclass(frozen=True)
class Check:
    """One row of verified.csv."""

    level: int
    iteration: int  # the run's, over all levels
    seconds: float  # the run's clock at that iteration, without the checks
    self_relative: float
    verified_relative: float | None  # None where the refined solve from rest failed
    verification_seconds: float  # the checks' time so far


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


def append_check(path: Path, check: Check, comm: MPI.Comm) -> None:
    """One row more of verified.csv (with its header when the file is new), on rank 0."""
    if comm.rank != 0:
        return
    path.parent.mkdir(parents=True, exist_ok=True)  # before the first checkpoint makes it
    new = not path.exists()
    with path.open("a") as f:
        if new:
            f.write(",".join(COLUMNS) + "\n")
        f.write(",".join("" if getattr(check, c) is None else repr(getattr(check, c))
                         for c in COLUMNS) + "\n")


def read_checks(path: Path) -> list[Check]:
    """verified.csv's rows (none where the file is missing)."""
    if not path.exists():
        return []
    rows = path.read_text().splitlines()[1:]
    out = []
    for row in rows:
        level, iteration, seconds, own, verified, spent = row.split(",")
        out.append(Check(int(level), int(iteration), float(seconds), float(own),
                         float(verified) if verified else None, float(spent)))
    return out


def first_below(checks: list[Check], level: float) -> Check | None:
    """The first check whose verified error is at most ``level`` (a fraction)."""
    return next((c for c in checks if c.verified_relative is not None
                 and c.verified_relative <= level), None)
