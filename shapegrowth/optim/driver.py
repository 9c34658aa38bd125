"""The optimisation driver: NLopt L-BFGS (default), MMA or SLSQP on a bounded design vector.

The driver sees only a :class:`DesignProblem` (the reduced functional's interface: its
size, bounds, current design, J and dJ, the alpha of a schedule and the scale of its
stopping test) and a list of :class:`Callback` objects, in the spirit of pyadjoint's
``ReducedFunctional`` and its ``eval_cb_post``: the checkpoint file and exact resume
(optim/checkpoint.py), and the progress log, the retry of a failed state from rest and the
physical branch (optim/callbacks.py) are callbacks.

L-BFGS keeps a few vector pairs, so its own work is O(n) per iteration (1.6 ms at 10^4
design DOFs, benchmarks/optimizer_cost.py); SLSQP's dense quasi-Newton matrix costs O(n^2)
memory and O(n^3) time (1.2 s per iteration at 1000 design DOFs, 54 s at 3000).  Measured
on the quarter-circle bend from no growth (scripts/reachable.py, 594 design DOFs, 100
iterations): L-BFGS 0.26 % shape error, SLSQP 0.084 % with 27 % of the run inside NLopt,
MMA 2.3 %.

An alpha schedule (``objective.hausdorff.alpha: [a1, a2, ...]``) runs in stages: each stage
optimises J at its alpha, from the design the last one ended with, until NLopt stops by its
own test or the stage's share of the remaining iterations is spent.

Every rank runs the same NLopt instance on the same global design vector (the ranks' owned
parts, gathered in rank order), so the iterates agree on every rank; the objective and its
gradient are evaluated collectively.  An "iteration" is one evaluation of J and dJ
requested by NLopt.

Move limits (MMA only): NLopt's MMA sets its initial asymptote distances to half the bound
range and ignores any initial step, so with the paper's eigenvalue bounds [0.01, 12] its
first trial moves every eigenvalue by about 3, far from any useful design (on the tiny
beam_wave the objective tripled and one trial took 628 Newton iterations).  MMA is
therefore run on a box of +-``move_limit`` around the current design, for at most
``restart_every`` evaluations, and the box is re-centred until MMA converges inside a box
or the iterations run out (beam_wave, coarse: 11.9 % shape error after 60 iterations in
boxes of 0.3, 14.5 % after 100 on the whole bounds).  SLSQP and L-BFGS run on the whole
bounds.  Where a box binds, MMA asks for the same point on its side again and again (on a
quadratic, 8 of a box's 10 evaluations: iterations of the budget, though the solve cache
answers them): the box is re-centred at the first repeat, which is not evaluated, and a
repeat inside the box is MMA standing still, converged.

The stopping test is the driver's, judged over a window of iterations: a stage ends as
converged when its best J has fallen by less than ``ftol_rel`` times |J| over the last
``ftol_window`` evaluations.  NLopt's own ftol tests judge one step: on the reachable
quarter arc (t/L = 1/25) one L-BFGS step's change of 1.3e-8 fell under the debiased
objective's absolute test (ftol_rel x rho_H(T, T) = 7.9e-8) at iteration 84, 0.444 %
verified, while J still fell 10 % every 20 iterations (0.089 % verified after 300;
docs/VERIFICATION.md, "Where the stopping test stops").  Relative to |J| itself the debiased
S, which tends to its discretisation's floor rather than to 0, is judged by its own
progress.  A stall (L-BFGS's line search finding no decrease) still ends a stage.

A state solve that fails and that no callback recovers (:class:`RetryFromRest` solves it
again from rest with smaller load steps), a failed adjoint solve or a non-finite J or dJ
ends the run with status ``failed: <reason>`` and the best design found so far.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import AdjointSolveError, StateSolveError
from ..status import Outcome
from .interface import Callback, DesignProblem, DriverResult, GlobalVector, Record, Step

if TYPE_CHECKING:
    from ..config import Config

log = logging.getLogger(__name__)

ALGORITHMS = {"mma": "LD_MMA", "slsqp": "LD_SLSQP", "lbfgs": "LD_LBFGS"}
SLSQP_LARGE = 1000  # design DOFs beyond which SLSQP's dense update dominates a run


@dataclass(frozen=True)
class DriverSettings:
    name: str
    algorithm: str  # a key of ALGORITHMS
    max_iterations: int
    alphas: tuple[float, ...]
    move_limit: float = 0.0
    restart_every: int = 50
    ftol_rel: float = 0.0
    xtol_rel: float = 0.0
    ftol_window: int = 20
    sharpness: tuple[float, ...] = ()  # growth.levels' projection, one stage each

    @classmethod
    def from_config(cls, cfg: Config) -> DriverSettings:
        o = cfg.optimizer
        return cls(cfg.name, o.algorithm, max(o.max_iterations, 1),
                   tuple(cfg.objective.hausdorff.alphas), o.move_limit, o.restart_every,
                   o.ftol_rel, o.xtol_rel, o.ftol_window,
                   tuple(cfg.growth.sharpness) if cfg.growth.levels is not None else ())

    def stages(self) -> list[tuple[float, float | None]]:
        """(alpha, sharpness) per stage: the alpha schedule at the first sharpness, then each
        further sharpness at the last alpha (sharpness None without growth.levels)."""
        first = self.sharpness[0] if self.sharpness else None
        return [(a, first) for a in self.alphas] + \
            [(self.alphas[-1], b) for b in self.sharpness[1:]]


class Driver:
    """NLopt on ``problem``, stage by stage of the alpha schedule (module doc)."""

    def __init__(self, problem: DesignProblem, settings: DriverSettings,
                 callbacks: Sequence[Callback] = ()):
        self.problem, self.settings = problem, settings
        self.callbacks = list(callbacks)
        self.comm = problem.comm
        self.vec = GlobalVector(self.comm, problem.size)
        self.history: list[Record] = []
        self.best: tuple[float, np.ndarray] | None = None
        self.failure: str | None = None
        self._tic = time.perf_counter()
        self._callback_time = 0.0
        self._end = 0  # evaluations allowed so far (the current stage's end)
        self._stage_start = 0  # the current stage's first evaluation
        # a stop of ours, pending until NLopt returns: "budget" (the stage's evaluations are
        # spent), "converged" (the window's test), "repeat" (MMA asked for the point it was
        # just given: module doc)
        self._stop: str | None = None
        self._chunk_last: np.ndarray | None = None  # the last point of this MMA box

    def local(self, x: np.ndarray) -> np.ndarray:
        """This rank's part of a design vector of the whole body (such as a result's best)."""
        return self.vec.local(x)

    @property
    def design_size(self) -> int:
        """The design vector's length, all ranks."""
        return self.vec.size

    # ---- NLopt's objective -----------------------------------------------------------------
    def _objective(self, x: np.ndarray, grad: np.ndarray) -> float:
        """NLopt's objective.  NLopt turns any exception raised here into a generic failure
        that reads like its own line search giving up, so one that is not a stop of ours
        (a callback's OSError, say) ends the run as failed, with its message and the best
        design so far, instead of passing for round-off."""
        import nlopt

        if self.failure is not None:  # L-BFGS may call once more after a stop
            raise nlopt.ForcedStop(self.failure)
        if self._stop is not None:
            raise nlopt.ForcedStop(self._stop)
        k = len(self.history)
        try:
            return self._objective_body(x, grad)
        except nlopt.ForcedStop:
            raise
        except Exception as err:
            # a call after a stop of ours may see that stop still pending (a SystemError
            # from the first C function called: disk_cone_from_axi, the call after the
            # budget's stop at iteration 40): the stop stands, it is no failure
            if self._stop is not None:
                raise nlopt.ForcedStop(self._stop) from None
            if self.failure is None:
                self.failure = f"at iteration {k}: {type(err).__name__}: {err}"
                log.error("%s", self.failure)
            raise nlopt.ForcedStop(self.failure) from None

    def _objective_body(self, x: np.ndarray, grad: np.ndarray) -> float:
        import nlopt

        tic = time.perf_counter()
        k = len(self.history)
        if k >= self._end:
            # NLopt's L-BFGS may ask for one evaluation past its maxeval: the budget is ours
            self._stop = "budget"
            raise nlopt.ForcedStop("iteration budget spent")
        if self._chunk_last is not None and np.array_equal(x, self._chunk_last):
            self._stop = "repeat"  # MMA's box binds: re-centre it, spend nothing (module doc)
            raise nlopt.ForcedStop("the same point again")
        if self._boxed:
            self._chunk_last = x.copy()
        try:
            answer = next((a for cb in self.callbacks if (a := cb.answer(k, x)) is not None),
                          None)
            if answer is not None:
                f, g, record = answer.objective, answer.gradient, answer.record
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
        self.history.append(record)
        if self.best is None or f < self.best[0]:
            self.best = (f, x.copy())
        step = Step(k, x, f, g, record, self.best[1], answer is not None)
        for cb in self.callbacks:
            cb.evaluated(step)
        self._callback_time += time.perf_counter() - tic
        if self.stalled():
            self._stop = "converged"
            log.info("converged: the best J fell by less than %g of |J| over the last %d "
                     "iterations (optimizer.ftol_rel, optimizer.ftol_window)",
                     self.settings.ftol_rel, self.settings.ftol_window)
            raise nlopt.ForcedStop("converged")
        return f

    @property
    def _boxed(self) -> bool:
        """MMA in move limits (module doc)."""
        return self.settings.algorithm == "mma" and self.settings.move_limit > 0

    def stalled(self) -> bool:
        """The stopping test (module doc): this stage's best J has fallen by at most
        ``ftol_rel`` |J| over its last ``ftol_window`` evaluations.  It reads the history
        only, so a resumed run stops where the uninterrupted one did."""
        s = self.settings
        fall = window_progress([r.objective for r in self.history[self._stage_start:]],
                               s.ftol_window)
        return s.ftol_rel > 0 and fall is not None and fall <= s.ftol_rel

    def _evaluate(self, k: int, x: np.ndarray, tic: float) -> tuple[float, np.ndarray, Record]:
        """J and dJ at ``x`` for NLopt's callback that started at ``tic``."""
        local = self.vec.local(x)
        try:
            ev = self.problem.evaluate(local, gradient=True)
        except StateSolveError as err:
            recovered = next((e for cb in self.callbacks
                              if (e := cb.recover(k, local, err)) is not None), None)
            if recovered is None:
                raise
            ev = recovered
        assert ev.gradient is not None
        g = self.vec.gather(ev.gradient)
        value = ev.value
        record = Record(k, value.total, value.rho_H, value.complexity, value.hausdorff,
                        float(np.linalg.norm(g)), ev.report.newton_iterations,
                        time.perf_counter() - self._tic, value.alpha,
                        tic - self._tic - self._callback_time)
        return value.total, g, record

    # ---- the run ---------------------------------------------------------------------------
    def run(self) -> DriverResult:
        import nlopt

        s = self.settings
        n, max_evals = self.vec.size, s.max_iterations
        lo, hi = self.problem.bounds()
        lo, hi = self.vec.gather(lo), self.vec.gather(hi)
        x = self.vec.gather(self.problem.current())
        alphas = s.alphas
        if s.algorithm == "slsqp" and n > SLSQP_LARGE:
            log.warning("SLSQP updates a dense n x n quasi-Newton matrix: at %d design DOFs its "
                        "own work grows like n^3 per iteration (measured 1.2 s at 1000, 54 s at "
                        "3000); optimizer.algorithm: lbfgs stays O(n)", n)
        log.info("optimising %s: %d design DOFs, %s, at most %d iterations%s", s.name, n,
                 s.algorithm.upper(), max_evals,
                 f", alpha {' -> '.join(f'{a:g}' for a in alphas)}" if len(alphas) > 1 else "")
        log.info("%5s %13s %13s %11s %10s %6s %9s", "iter", "J", "rho_H", "Hausdorff", "|dJ/dm|",
                 "Newton", "seconds")
        code = nlopt.MAXEVAL_REACHED
        stages = s.stages()
        for stage, (alpha, beta) in enumerate(stages):
            if beta is not None and (stage == 0 or beta != stages[stage - 1][1]):
                self._outside(self.problem.set_sharpness, beta)
                if stage > 0:
                    log.info("sharpness %g (stage %d of %d)", beta, stage + 1, len(stages))
            if stage > 0:
                # J changes with alpha or the sharpness: a design is best only against the
                # stage's own J
                self._outside(self.problem.set_alpha, alpha)
                self.best = None
                if alpha != stages[stage - 1][0]:
                    log.info("alpha %g (stage %d of %d)", alpha, stage + 1, len(stages))
            # each stage may use its share of what is left; the last one everything
            left = max_evals - len(self.history)
            end = len(self.history) + left // (len(stages) - stage)
            x, code = self._stage(x, lo, hi, end)
            if self.failure or code == nlopt.FORCED_STOP or len(self.history) >= max_evals:
                break
        optimizer_seconds = (time.perf_counter() - self._tic) - self._callback_time
        if self.failure:
            outcome = Outcome.failed(self.failure)
        elif len(self.history) >= max_evals:
            outcome = Outcome.max_iterations()
        elif code > 0 or code == nlopt.ROUNDOFF_LIMITED:
            outcome = Outcome.converged()  # by NLopt's own test, or no decrease left
        else:
            outcome = Outcome.failed(f"NLopt returned {code}")
        best = self.best[1] if self.best is not None else x
        result = DriverResult(outcome, best, self.history, optimizer_seconds)
        for cb in self.callbacks:
            cb.finished(result)
        return result

    def _outside(self, call, *args):
        """A call to the problem outside NLopt's loop (its stopping scale, a new alpha: the
        target's own rho_H, 0.39 s of the free square's 0.61 s once counted as NLopt's
        time), timed with J and dJ, not as the optimiser's."""
        tic = time.perf_counter()
        try:
            return call(*args)
        finally:
            self._callback_time += time.perf_counter() - tic

    def _stage(self, x: np.ndarray, lo: np.ndarray, hi: np.ndarray,
               end: int) -> tuple[np.ndarray, int]:
        """NLopt from ``x`` until the evaluation count reaches ``end`` or it stops by its own
        test; returns its last design and result code."""
        import nlopt

        s = self.settings
        n = self.vec.size
        code = nlopt.MAXEVAL_REACHED
        self._end = end
        self._stage_start = len(self.history)
        # SLSQP and L-BFGS control their steps by a line search, and a restart would discard
        # their quasi-Newton model (beam_wave, 100 SLSQP iterations: 2.1 % shape error on the
        # whole bounds, 12-14 % in boxes): move limits are for MMA.
        limit = s.move_limit if self._boxed else 0.0
        while len(self.history) < end:
            box_lo = np.maximum(lo, x - limit) if limit > 0 else lo
            box_hi = np.minimum(hi, x + limit) if limit > 0 else hi
            chunk = end - len(self.history)
            if limit > 0:
                chunk = min(chunk, s.restart_every)
            opt = nlopt.opt(getattr(nlopt, ALGORITHMS[s.algorithm]), n)
            opt.set_lower_bounds(box_lo)
            opt.set_upper_bounds(box_hi)
            opt.set_min_objective(self._objective)
            opt.set_maxeval(chunk)
            # no NLopt ftol: the driver's own window decides (module doc)
            if s.xtol_rel > 0:
                opt.set_xtol_rel(s.xtol_rel)
            start = len(self.history)
            self._chunk_last = None
            try:
                x = opt.optimize(np.clip(x, box_lo, box_hi))
                code = opt.last_optimize_result()
            except _nlopt_stops(nlopt):
                # a stop from the callback; L-BFGS reports ours as a generic "nlopt failure"
                stop, self._stop = self._stop, None  # the next box or stage starts afresh
                if stop == "repeat":
                    assert self._chunk_last is not None
                    x = self._chunk_last
                    code = nlopt.MAXEVAL_REACHED if _on_box(x, box_lo, box_hi, lo, hi) else \
                        nlopt.XTOL_REACHED  # MMA stands still inside its box: converged
                    if code == nlopt.XTOL_REACHED or len(self.history) == start + 1:
                        break
                    continue
                if stop == "converged":
                    code = nlopt.FTOL_REACHED
                elif stop is None:
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
                    code = nlopt.MAXEVAL_REACHED
                return (self.best[1] if self.best is not None else x), code
            at_box = limit > 0 and _on_box(x, box_lo, box_hi, lo, hi)
            if code != nlopt.MAXEVAL_REACHED and not at_box:
                break  # converged inside the box: a true optimum, not a move limit
            if len(self.history) == start:
                break
        return x, code


def window_progress(totals: Sequence[float], window: int) -> float | None:
    """How far the best of ``totals`` fell over its last ``window`` values, relative to
    |the best|; None before the window is full."""
    if len(totals) <= window:
        return None
    before, now = min(totals[:-window]), min(totals)
    return (before - now) / max(abs(now), 1e-300)


def _on_box(x: np.ndarray, box_lo: np.ndarray, box_hi: np.ndarray, lo: np.ndarray,
            hi: np.ndarray) -> bool:
    """Whether ``x`` stands on a move limit (a side of the box that is not a bound)."""
    return bool(np.any(((x <= box_lo) & (box_lo > lo)) | ((x >= box_hi) & (box_hi < hi))))


def _nlopt_stops(nlopt) -> tuple[type[BaseException], ...]:
    """What ``opt.optimize`` raises when a callback stops it or L-BFGS gives up: NLopt 2.7's
    ForcedStop and RuntimeError; NLopt 2.11 (the pip wheel beside dolfinx 0.11) raises its
    own ``nlopt.exception`` classes, which are not RuntimeErrors."""
    extra = getattr(nlopt, "exception", None)
    return (nlopt.ForcedStop, RuntimeError, *([extra] if isinstance(extra, type) else []))
