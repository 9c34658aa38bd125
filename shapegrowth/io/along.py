"""verified.csv: the verified shape error along a run (``verify.every``), one row per check
(optim/verification.py's :class:`VerifyEvery` makes them): the level, the iteration, the
run's clock at that iteration without the checks themselves (what a run without them would
have taken to get there), the self-reported and the verified shape error, and the checks'
own seconds so far.  ``shapegrowth bench --runs`` reads the time to a verified 1 % and
0.3 % from it.  A resumed run appends; replayed iterations are not checked again.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

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
