"""checkpoint.h5 and exact resume, as a callback of the optimisation driver.

``checkpoint.h5`` records every evaluation's J and dJ (and a checksum of its design), the
history, the best design and the state after the last evaluation.  ``--resume`` restarts
NLopt from the initial design and answers its first requests from the record (no solves) -
NLopt's algorithms are deterministic, so they ask for the same designs, which the
checksums confirm - then continues with real evaluations, the state put back where the
interrupted run had it.  The resumed run therefore has the same iterates and numbering as
one that was never interrupted.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import os
from pathlib import Path
from typing import Protocol

import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import ResumeError
from ..timing import Timer
from .interface import Answer, Callback, DriverResult, GlobalVector, Record, Step

log = logging.getLogger(__name__)


class Resumable(Protocol):
    """What exact resume needs of the reduced functional."""

    comm: MPI.Comm

    @property
    def size(self) -> int: ...

    def state_snapshot(self) -> np.ndarray: ...

    def restore(self, m: np.ndarray, state: np.ndarray) -> None: ...


def checksum(x: np.ndarray) -> str:
    return hashlib.sha1(np.ascontiguousarray(x, dtype=np.float64).tobytes()).hexdigest()


class Checkpoint:
    """Every evaluation's (J, dJ, checksum of x), the history and the best design."""

    def __init__(self, path: Path, comm: MPI.Comm):
        self.path, self.comm = path, comm
        self.f: list[float] = []
        self.g: list[np.ndarray] = []
        self.sums: list[str] = []
        self.history: list[Record] = []
        self.best_x: np.ndarray | None = None
        self.state: np.ndarray | None = None  # displacement after the last evaluation
        self.mpi_size = comm.size

    def add(self, x: np.ndarray, f: float, g: np.ndarray, record: Record) -> None:
        self.f.append(f)
        self.g.append(g.copy())
        self.sums.append(checksum(x))
        self.history.append(record)

    def write(self) -> None:
        if self.comm.rank == 0:
            h5py = compat.h5py()
            tmp = self.path.with_suffix(".tmp.h5")
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with h5py.File(tmp, "w") as h5:
                h5["f"] = np.array(self.f)
                h5["g"] = np.array(self.g) if self.g else np.zeros((0, 0))
                h5["checksums"] = np.array(self.sums, dtype="S40")
                h5["history"] = np.array([dataclasses.astuple(r) for r in self.history])
                if self.best_x is not None:
                    h5["best_x"] = self.best_x
                if self.state is not None:
                    h5["state"] = self.state
                h5.attrs["mpi_size"] = self.mpi_size
            os.replace(tmp, self.path)  # a kill never leaves half a checkpoint
        self.comm.barrier()

    @classmethod
    def read(cls, path: Path, comm: MPI.Comm) -> Checkpoint:
        h5py = compat.h5py()
        ck = cls(path, comm)
        data = None
        if comm.rank == 0:
            with h5py.File(path, "r") as h5:
                data = {k: h5[k][()] for k in h5}
                data["mpi_size"] = int(h5.attrs["mpi_size"])
        data = comm.bcast(data, root=0)
        ck.f = list(data["f"])
        ck.g = list(data["g"]) if len(data["f"]) else []
        ck.sums = [s.decode() for s in data["checksums"]]
        nan = float("nan")  # alpha and the optimiser's time: absent from old checkpoints
        ck.history = [Record(int(r[0]), float(r[1]), float(r[2]), float(r[3]), float(r[4]),
                             float(r[5]), int(r[6]), float(r[7]),
                             float(r[8]) if len(r) > 8 else nan,
                             float(r[9]) if len(r) > 9 else nan,
                             int(r[10]) if len(r) > 10 else 0)
                      for r in data["history"]]
        ck.best_x = data.get("best_x")
        ck.state = data.get("state")
        ck.mpi_size = data["mpi_size"]
        return ck


class CheckpointFile(Callback):
    """Writes checkpoint.h5 every ``every`` evaluations and at the end; with ``resume``,
    answers the recorded evaluations first (module doc)."""

    def __init__(self, path: Path, problem: Resumable, every: int, resume: bool = False,
                 timer: Timer | None = None):
        self.path, self.problem, self.every = path, problem, every
        self.comm = problem.comm
        self.timer = timer or Timer()
        self.checkpoint = Checkpoint(path, self.comm)
        self.design_vec = GlobalVector(self.comm, problem.size)
        self.state_vec = GlobalVector(self.comm, len(problem.state_snapshot()))
        self.replay: Checkpoint | None = None
        if resume:
            if not path.is_file():
                raise ResumeError(f"--resume: no checkpoint at {path}")
            self.replay = Checkpoint.read(path, self.comm)
            if self.replay.mpi_size != self.comm.size:
                raise ResumeError(f"--resume: the checkpoint was written by {self.replay.mpi_size} "
                                  f"ranks; resume with mpirun -n {self.replay.mpi_size}")
        self._best: np.ndarray | None = None

    def answer(self, iteration: int, x: np.ndarray) -> Answer | None:
        replay = self.replay
        if replay is None or iteration >= len(replay.f):
            return None
        if checksum(x) != replay.sums[iteration]:
            raise ResumeError(f"--resume: iteration {iteration} asks for another design than "
                              "the checkpoint recorded (config or code changed?)")
        if iteration == len(replay.f) - 1:
            self._restore_state(x)
        return Answer(float(replay.f[iteration]), np.asarray(replay.g[iteration]),
                      replay.history[iteration])

    def _restore_state(self, x: np.ndarray) -> None:
        """Put the state where the interrupted run had it after the last recorded
        evaluation, so the next solve warm-starts exactly as it did there."""
        assert self.replay is not None
        if self.replay.state is None or len(self.replay.state) != self.state_vec.size:
            return  # an old checkpoint: the next solve starts from rest
        self.problem.restore(self.design_vec.local(x), self.state_vec.local(self.replay.state))

    def evaluated(self, step: Step) -> None:
        self.checkpoint.add(step.x, step.objective, step.gradient, step.record)
        self._best = step.best_x
        if (step.iteration + 1) % self.every == 0:
            self.write()

    def finished(self, result: DriverResult) -> None:
        self._best = result.best
        self.write()

    def write(self) -> None:
        with self.timer("io"):
            self.checkpoint.state = self.state_vec.gather(self.problem.state_snapshot())
            self.checkpoint.best_x = self._best
            self.checkpoint.write()
