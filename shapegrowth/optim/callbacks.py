"""The driver's stock callbacks: the progress log, the retry of a failed state from rest,
the physical branch (``optimizer.from_rest_every``) and the state's tolerance from the
optimiser's progress (``solver.rtol_far``).  The checkpoint and exact resume are io's
(optim/checkpoint.py)."""

from __future__ import annotations

import logging
from typing import Protocol

import numpy as np

from ..errors import StateSolveError
from .interface import Callback, DesignProblem, Record, Step
from .problem import Evaluation

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
    what growing the body does (docs/STABILITY.md)."""

    def __init__(self, problem: Restartable, every: int):
        self.problem, self.every = problem, every

    def evaluated(self, step: Step) -> None:
        if self.every and (step.iteration + 1) % self.every == 0:
            self.problem.restart_from_rest()


class ProgressTolerance(Callback):
    """Newton's tolerance for the next warm state solve, loose far from the optimum and tight
    near it: ``rtol * progress / ftol_rel`` within [rtol, rtol_far], where progress is the
    change of J between the last two evaluations relative to |J|, or to rho_H(T, T) where
    that is larger (the debiased J tends to 0: ``stopping_scale``).
    A warm solve's relative tolerance is taken of the residual the design step made, so the
    error it leaves in J is about the tolerance times the step's own change of J; where J
    still changes by 1e-3 per step, 1e-6 of that is far below what the optimiser can see,
    and where the change falls to the stopping test's ftol_rel the configured rtol holds.
    The tolerance comes from the driver's history only (replayed steps included), so a
    resumed run solves with the tolerances of the uninterrupted one."""

    def __init__(self, problem: Tolerant, rtol: float, rtol_far: float, ftol_rel: float):
        self.problem = problem
        self.rtol, self.rtol_far, self.ftol_rel = rtol, rtol_far, ftol_rel
        self._last: float | None = None

    def tolerance(self, previous: float, current: float, scale: float = 0.0) -> float:
        size = max(abs(current), abs(previous), scale, 1e-300)
        progress = abs(current - previous) / size
        return float(np.clip(self.rtol * progress / self.ftol_rel, self.rtol, self.rtol_far))

    def evaluated(self, step: Step) -> None:
        if self._last is not None:
            scale = self.problem.stopping_scale()
            self.problem.set_warm_rtol(self.tolerance(self._last, step.objective, scale))
        self._last = step.objective


class Restartable(DesignProblem, Protocol):
    def restart_from_rest(self, step_scale: float = 1.0) -> None: ...


class Tolerant(DesignProblem, Protocol):
    def set_warm_rtol(self, rtol: float | None) -> None: ...


def line(r: Record) -> str:
    return (f"{r.iteration:5d} {r.objective:13.6e} {r.rho_H:13.6e} {r.hausdorff:11.4e} "
            f"{r.grad_norm:10.3e} {r.newton_iterations:6d} {r.seconds:9.1f}")
