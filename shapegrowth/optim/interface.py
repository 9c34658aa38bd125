"""What the optimisation driver and its callbacks exchange: the design problem it sees
(:class:`DesignProblem`, the reduced functional's interface), the records of each
evaluation, the callbacks' hooks and the design vector gathered over the ranks."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from mpi4py import MPI

from ..errors import StateSolveError
from ..status import Outcome
from .problem import Evaluation


class DesignProblem(Protocol):
    """What the driver needs of a reduced functional J(m) (:class:`ReducedFunctional`).
    ``m`` is always this rank's share of the design; calls are collective."""

    comm: MPI.Comm

    @property
    def size(self) -> int: ...

    def current(self) -> np.ndarray: ...

    def bounds(self) -> tuple[np.ndarray, np.ndarray]: ...

    def evaluate(self, m: np.ndarray, gradient: bool = True) -> Evaluation: ...

    def set_alpha(self, alpha: float) -> None: ...

    def set_sharpness(self, beta: float) -> None: ...

    def stopping_scale(self) -> float: ...


@dataclass
class Record:
    """One row of history.csv: one evaluation of J and dJ."""

    iteration: int
    objective: float
    rho_H: float
    complexity: float
    hausdorff: float
    grad_norm: float
    newton_iterations: int
    seconds: float
    alpha: float  # the sharpness of rho_H this iteration was evaluated at
    optimizer_seconds: float  # NLopt's own time so far (the run's time outside J and dJ)
    level: int = 0  # the coarse-to-fine level (optimizer.levels)


@dataclass(frozen=True)
class Answer:
    """An evaluation a callback answers without solving (a resumed run's record)."""

    objective: float
    gradient: np.ndarray  # global
    record: Record


@dataclass(frozen=True)
class Step:
    """What the driver hands the callbacks after each evaluation."""

    iteration: int
    x: np.ndarray  # the global design
    objective: float
    gradient: np.ndarray  # global
    record: Record
    best_x: np.ndarray  # the best design of the current stage so far (global)
    replayed: bool


@dataclass(frozen=True)
class DriverResult:
    outcome: Outcome
    best: np.ndarray  # the best design (global); the last one where none was evaluated
    history: list[Record]
    optimizer_seconds: float  # NLopt's own time, outside J and dJ


class Callback:
    """Hooks the driver calls; the defaults do nothing."""

    def answer(self, iteration: int, x: np.ndarray) -> Answer | None:
        """An evaluation known without solving, or None (solve it)."""
        return None

    def recover(self, iteration: int, m: np.ndarray, error: StateSolveError) -> Evaluation | None:
        """An evaluation obtained another way after the state solve failed, or None."""
        return None

    def evaluated(self, step: Step) -> None:
        """After each evaluation, answered or solved."""

    def finished(self, result: DriverResult) -> None:
        """Once, when the run ends (also by failure)."""


class GlobalVector:
    """The ranks' owned entries of a distributed vector gathered into one, in rank order."""

    def __init__(self, comm: MPI.Comm, n_local: int):
        self.comm = comm
        self.counts = np.array(comm.allgather(n_local), dtype=np.int64)
        self.offsets = np.concatenate([[0], np.cumsum(self.counts)])
        self.size = int(self.offsets[-1])
        self.slice = slice(int(self.offsets[comm.rank]), int(self.offsets[comm.rank + 1]))

    def gather(self, local: np.ndarray) -> np.ndarray:
        out = np.empty(self.size)
        self.comm.Allgatherv(np.ascontiguousarray(local, dtype=float),
                             [out, self.counts, self.offsets[:-1], MPI.DOUBLE])
        return out

    def local(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(x[self.slice], dtype=float)
