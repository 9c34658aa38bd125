"""The driver's stock callbacks: the progress log, the retry of a failed state from rest,
and the physical branch (``optimizer.from_rest_every``).  The checkpoint and exact resume
are io's (io/checkpoint.py)."""

from __future__ import annotations

import logging
from typing import Protocol

import numpy as np

from .driver import Callback, DesignProblem, Record, Step
from .problem import Evaluation, StateSolveError

log = logging.getLogger(__name__)


class ProgressLog(Callback):
    """One log line per evaluation (the table the run prints)."""

    def evaluated(self, step: Step) -> None:
        log.info("%s%s", line(step.record), "  (replayed)" if step.replayed else "")


class RetryFromRest(Callback):
    """A state solve that fails on the warm start is tried once more from rest, with load
    steps a quarter of the configured first step."""

    def __init__(self, problem: Restartable, step_scale: float = 0.25):
        self.problem, self.step_scale = problem, step_scale

    def recover(self, iteration: int, m: np.ndarray, error: StateSolveError) -> Evaluation | None:
        log.warning("iteration %d: %s; retrying from rest with smaller load steps", iteration,
                    error)
        self.problem.restart_from_rest(self.step_scale)
        return self.problem.evaluate(m, gradient=True)


class FromRestEvery(Callback):
    """The physical branch: after every ``every``-th evaluation the state is dropped, so the
    next one is solved from rest, as the body grows, and the warm starts continue from that
    equilibrium.  A thin body can have several equilibria for one growth; the optimiser's
    warm starts follow their own path among them, and only the one reached from rest is
    what growing the body does (docs/TRADEOFFS.md)."""

    def __init__(self, problem: Restartable, every: int):
        self.problem, self.every = problem, every

    def evaluated(self, step: Step) -> None:
        if self.every and (step.iteration + 1) % self.every == 0:
            self.problem.restart_from_rest()


class Restartable(DesignProblem, Protocol):
    def restart_from_rest(self, step_scale: float = 1.0) -> None: ...


def line(r: Record) -> str:
    return (f"{r.iteration:5d} {r.objective:13.6e} {r.rho_H:13.6e} {r.hausdorff:11.4e} "
            f"{r.grad_norm:10.3e} {r.newton_iterations:6d} {r.seconds:9.1f}")
