"""The optimisation driver: NLopt L-BFGS (default), MMA or SLSQP on the bounded design vector.

L-BFGS keeps a few vector pairs, so its own work is O(n) per iteration (1.6 ms at 10^4
design DOFs, benchmarks/optimizer_cost.py); SLSQP's dense quasi-Newton matrix costs O(n^2)
memory and O(n^3) time (1.2 s per iteration at 1000 design DOFs, 54 s at 3000).  Measured
on the quarter-circle bend from no growth (scripts/reachable.py, 594 design DOFs, 100
iterations): L-BFGS 0.26 % shape error, SLSQP 0.084 % with 27 % of the run inside NLopt,
MMA 2.3 %.

An alpha schedule (``objective.hausdorff.alpha: [a1, a2, ...]``) runs in stages: each stage
optimises J at its alpha, from the design the last one ended with, until NLopt stops by its
own test or the stage's share of the remaining iterations is spent.

Every rank runs the same NLopt instance on the same global design vector (the
ranks' owned parts, gathered in rank order), so the iterates agree on every
rank; the objective and its gradient are evaluated collectively.  An
"iteration" is one evaluation of J and dJ requested by NLopt.

Checkpoints and exact resume: ``checkpoint.h5`` records every evaluation's J and
dJ (and a checksum of its design).  ``--resume`` restarts NLopt from the initial
design and answers its first requests from the record (no solves) - MMA and
SLSQP are deterministic, so they ask for the same designs, which the checksums
confirm - then continues with real evaluations.  The resumed run therefore has
the same iterates and numbering as one that was never interrupted.

Move limits (MMA only): NLopt's MMA sets its initial asymptote distances to half
the bound range and ignores any initial step, so with the paper's eigenvalue
bounds [0.01, 12] its first trial moves every eigenvalue by about 3, far from any
useful design (on the tiny beam_wave the objective tripled and one trial took
628 Newton iterations).  MMA is therefore run on a box of +-``move_limit``
around the current design, for at most ``restart_every`` evaluations, and the
box is re-centred until MMA converges inside a box or the iterations run out
(beam_wave, coarse: 11.9 % shape error after 60 iterations in boxes of 0.3,
14.5 % after 100 on the whole bounds).  SLSQP runs on the whole bounds.

A state solve that fails is retried once from rest with smaller load steps; if
that fails too, the run stops with status ``failed: <reason>`` and the best
design found so far is written.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from mpi4py import MPI

from .adjoint import AdjointSolveError
from .problem import ReducedFunctional, StateSolveError

log = logging.getLogger(__name__)

ALGORITHMS = {"mma": "LD_MMA", "slsqp": "LD_SLSQP", "lbfgs": "LD_LBFGS"}
SLSQP_LARGE = 1000  # design DOFs beyond which SLSQP's dense update dominates a run


@dataclass
class Record:
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


class GlobalVector:
    """The ranks' owned design entries gathered into one vector, in rank order."""

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
            import h5py

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
        import h5py

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
        ck.history = [Record(int(r[0]), *map(float, r[1:6]), int(r[6]), float(r[7]),
                             float(r[8]) if len(r) > 8 else float("nan"),
                             float(r[9]) if len(r) > 9 else float("nan"))
                      for r in data["history"]]
        ck.best_x = data.get("best_x")
        ck.state = data.get("state")
        ck.mpi_size = data["mpi_size"]
        return ck


class ResumeError(RuntimeError):
    pass


class Optimizer:
    def __init__(self, rf: ReducedFunctional, out: Path, resume: bool = False):
        self.rf, self.cfg, self.out = rf, rf.cfg, out
        self.comm = rf.comm
        self.vec = GlobalVector(self.comm, rf.size)
        V = rf.model.state.V
        self.u_vec = GlobalVector(self.comm, V.dofmap.index_map.size_local * V.dofmap.index_map_bs)
        self.best: tuple[float, np.ndarray] | None = None
        self.failure: str | None = None
        self.checkpoint = Checkpoint(out / "checkpoint.h5", self.comm)
        self.replay: Checkpoint | None = None
        if resume:
            path = out / "checkpoint.h5"
            if not path.is_file():
                raise ResumeError(f"--resume: no checkpoint at {path}")
            self.replay = Checkpoint.read(path, self.comm)
            if self.replay.mpi_size != self.comm.size:
                raise ResumeError(f"--resume: the checkpoint was written by {self.replay.mpi_size} "
                                  f"ranks; resume with mpirun -n {self.replay.mpi_size}")
        self._tic = time.perf_counter()
        self._callback_time = 0.0
        self._end = 0  # evaluations allowed so far (the current stage's end)
        self._over_budget = False

    @property
    def history(self) -> list[Record]:
        """One record per iteration so far (kept by the checkpoint)."""
        return self.checkpoint.history

    # ---- NLopt callback --------------------------------------------------------------------
    def _objective(self, x: np.ndarray, grad: np.ndarray) -> float:
        import nlopt

        tic = time.perf_counter()
        k = len(self.history)
        if k >= self._end:
            # NLopt's L-BFGS may ask for one evaluation past its maxeval: the budget is ours
            self._over_budget = True
            raise nlopt.ForcedStop("iteration budget spent")
        try:
            if self.replay is not None and k < len(self.replay.f):
                f, g, record = self._replayed(k, x)
            else:
                f, g, record = self._evaluate(k, x, tic)
        except StateSolveError as err:
            self.failure = f"state solve failed at iteration {k}: {err}"
            raise nlopt.ForcedStop(self.failure) from None
        except AdjointSolveError as err:
            self.failure = f"at iteration {k}: {err}"
            raise nlopt.ForcedStop(self.failure) from None
        if not (np.isfinite(f) and np.isfinite(g).all()):
            # never hand NaN or inf to NLopt: it would wander off with them silently
            bad = "objective" if not np.isfinite(f) else "gradient"
            self.failure = (f"non-finite {bad} at iteration {k} (J = {f}); stopped at the best "
                            "design")
            log.error(self.failure)
            raise nlopt.ForcedStop(self.failure)
        if grad.size:
            grad[:] = g
        self.checkpoint.add(x, f, g, record)
        if self.best is None or f < self.best[0]:
            self.best = (f, x.copy())
        if (k + 1) % self.cfg.output.checkpoint_every == 0:
            with self.rf.timer("io"):
                self._write_checkpoint()
        self._callback_time += time.perf_counter() - tic
        return f

    def _optimizer_time(self, callback_start: float) -> float:
        """NLopt's own time up to the callback that started at ``callback_start``."""
        return callback_start - self._tic - self._callback_time

    def _replayed(self, k: int, x: np.ndarray) -> tuple[float, np.ndarray, Record]:
        if checksum(x) != self.replay.sums[k]:
            raise ResumeError(f"--resume: iteration {k} asks for another design than the "
                              "checkpoint recorded (config or code changed?)")
        record = self.replay.history[k]
        log.info("%s  (replayed)", _line(record))
        if k == len(self.replay.f) - 1:
            self._restore_state(x)
        return float(self.replay.f[k]), np.asarray(self.replay.g[k]), record

    def _write_checkpoint(self) -> None:
        u = self.rf.model.state.u
        self.checkpoint.state = self.u_vec.gather(u.x.array[:self.u_vec.counts[self.comm.rank]])
        self.checkpoint.best_x = self.best[1] if self.best is not None else None
        self.checkpoint.write()

    def _restore_state(self, x: np.ndarray) -> None:
        """Put the state where the interrupted run had it after the last recorded
        evaluation, so the next solve warm-starts exactly as it did there."""
        if self.replay.state is None or len(self.replay.state) != self.u_vec.size:
            return  # an old checkpoint: the next solve starts from rest
        rf, state = self.rf, self.rf.model.state
        rf._apply(self.vec.local(x))
        state.u.x.array[:self.u_vec.counts[self.comm.rank]] = self.u_vec.local(self.replay.state)
        state.u.x.scatter_forward()
        state.adopt_equilibrium()

    def _evaluate(self, k: int, x: np.ndarray, tic: float) -> tuple[float, np.ndarray, Record]:
        """J and dJ at ``x`` for NLopt's callback that started at ``tic``."""
        local = self.vec.local(x)
        try:
            ev = self.rf.evaluate(local, gradient=True)
        except StateSolveError as first:
            log.warning("iteration %d: %s; retrying from rest with smaller load steps", k, first)
            ev = self._retry_from_rest(local)
        g = self.vec.gather(ev.gradient)
        value = ev.value
        record = Record(k, value.total, value.rho_H, value.complexity, value.hausdorff,
                        float(np.linalg.norm(g)), ev.report.newton_iterations,
                        time.perf_counter() - self._tic, value.alpha, self._optimizer_time(tic))
        log.info(_line(record))
        return ev.value.total, g, record

    def _retry_from_rest(self, local: np.ndarray):
        state = self.rf.model.state
        self.rf.restart_from_rest()
        state.initial_step_scale = 0.25
        try:
            return self.rf.evaluate(local, gradient=True)
        finally:
            state.initial_step_scale = 1.0

    # ---- the run ---------------------------------------------------------------------------
    def run(self) -> tuple[str, np.ndarray]:
        """Optimise stage by stage of the alpha schedule (one stage without one); within a
        stage, MMA works in boxes of +-move_limit around the current design (module doc)."""
        import nlopt

        opt_cfg = self.cfg.optimizer
        n, max_evals = self.vec.size, max(opt_cfg.max_iterations, 1)
        lo, hi = self.rf.bounds()
        lo, hi = self.vec.gather(lo), self.vec.gather(hi)
        x = self.vec.gather(self.rf.current())
        alphas = self.cfg.objective.hausdorff.alphas
        if opt_cfg.algorithm == "slsqp" and n > SLSQP_LARGE:
            log.warning("SLSQP updates a dense n x n quasi-Newton matrix: at %d design DOFs its "
                        "own work grows like n^3 per iteration (measured 1.2 s at 1000, 54 s at "
                        "3000); optimizer.algorithm: lbfgs stays O(n)", n)
        log.info("optimising %s: %d design DOFs, %s, at most %d iterations%s", self.cfg.name, n,
                 opt_cfg.algorithm.upper(), max_evals,
                 f", alpha {' -> '.join(f'{a:g}' for a in alphas)}" if len(alphas) > 1 else "")
        log.info("%5s %13s %13s %11s %10s %6s %9s", "iter", "J", "rho_H", "Hausdorff", "|dJ/dm|",
                 "Newton", "seconds")
        code = nlopt.MAXEVAL_REACHED
        for stage, alpha in enumerate(alphas):
            if stage > 0:
                # J changes with alpha: a design is best only against the stage's own J
                self.rf.set_alpha(alpha)
                self.best = None
                log.info("alpha %g (stage %d of %d)", alpha, stage + 1, len(alphas))
            # each stage may use its share of what is left; the last one everything
            left = max_evals - len(self.history)
            end = len(self.history) + left // (len(alphas) - stage)
            x, code = self._stage(x, lo, hi, end)
            if self.failure or code == nlopt.FORCED_STOP or len(self.history) >= max_evals:
                break
        self.rf.timer.totals["optimizer"] += (time.perf_counter() - self._tic) - self._callback_time
        with self.rf.timer("io"):
            self._write_checkpoint()
        if self.failure:
            status = f"failed: {self.failure}"
        elif len(self.history) >= max_evals:
            status = "max_iterations"
        elif code > 0 or code == nlopt.ROUNDOFF_LIMITED:
            status = "converged"  # by NLopt's own test, or no decrease left to round-off
        else:
            status = f"failed: NLopt returned {code}"
        best = self.best[1] if self.best is not None else x
        return status, best

    def _stage(self, x: np.ndarray, lo: np.ndarray, hi: np.ndarray,
               end: int) -> tuple[np.ndarray, int]:
        """NLopt from ``x`` until the evaluation count reaches ``end`` or it stops by its own
        test; returns its last design and result code."""
        import nlopt

        opt_cfg = self.cfg.optimizer
        n = self.vec.size
        code = nlopt.MAXEVAL_REACHED
        self._end = end
        # SLSQP and L-BFGS control their steps by a line search, and a restart would discard
        # their quasi-Newton model (beam_wave, 100 SLSQP iterations: 2.1 % shape error on the
        # whole bounds, 12-14 % in boxes): move limits are for MMA.
        limit = opt_cfg.move_limit if opt_cfg.algorithm == "mma" else 0.0
        while len(self.history) < end:
            box_lo = np.maximum(lo, x - limit) if limit > 0 else lo
            box_hi = np.minimum(hi, x + limit) if limit > 0 else hi
            chunk = end - len(self.history)
            if limit > 0:
                chunk = min(chunk, opt_cfg.restart_every)
            opt = nlopt.opt(getattr(nlopt, ALGORITHMS[opt_cfg.algorithm]), n)
            opt.set_lower_bounds(box_lo)
            opt.set_upper_bounds(box_hi)
            opt.set_min_objective(self._objective)
            opt.set_maxeval(chunk)
            if opt_cfg.ftol_rel > 0:
                opt.set_ftol_rel(opt_cfg.ftol_rel)
                scale = self.rf.objective.stopping_scale()
                if scale > 0:  # the debiased S tends to 0: relative to rho_H(T, T) instead
                    opt.set_ftol_abs(opt_cfg.ftol_rel * scale)
            if opt_cfg.xtol_rel > 0:
                opt.set_xtol_rel(opt_cfg.xtol_rel)
            start = len(self.history)
            try:
                x = opt.optimize(np.clip(x, box_lo, box_hi))
                code = opt.last_optimize_result()
            except (nlopt.ForcedStop, RuntimeError):
                # a stop from the callback; L-BFGS reports ours as a generic "nlopt failure"
                if not self._over_budget:
                    if self.failure is not None:
                        return x, nlopt.FORCED_STOP
                    if len(self.history) == start:
                        raise  # not a stop: NLopt refused to start
                    # NLopt's own failure: L-BFGS's line search found no decrease (disk_cone,
                    # iteration 80: J equal to 7 digits over its last 10 evaluations).  The
                    # stage is over; its best design is kept.
                    log.warning("NLopt stopped: its line search found no further decrease "
                                "(round-off); the best design so far is kept")
                    code = nlopt.ROUNDOFF_LIMITED
                else:
                    self._over_budget = False
                    code = nlopt.MAXEVAL_REACHED
                return (self.best[1] if self.best is not None else x), code
            at_box = limit > 0 and np.any(((x <= box_lo) & (box_lo > lo))
                                          | ((x >= box_hi) & (box_hi < hi)))
            if code != nlopt.MAXEVAL_REACHED and not at_box:
                break  # converged inside the box: a true optimum, not a move limit
            if len(self.history) == start:
                break
        return x, code


def _line(r: Record) -> str:
    return (f"{r.iteration:5d} {r.objective:13.6e} {r.rho_H:13.6e} {r.hausdorff:11.4e} "
            f"{r.grad_norm:10.3e} {r.newton_iterations:6d} {r.seconds:9.1f}")
