"""The reduced functional J(m) of (5.6) and its gradient, for the design vector m.

m holds this rank's owned nodal values of the design fields (the unfiltered
lambda_i listed in ``growth.eigenvalues.design``, then, for ``frame: free``, the
theta_i), field after field.  One evaluation is the chain rule read forwards,
the gradient the same chain backwards:

    filter.forward [-> P] -> C_g -> state solve -> J (rho_H + complexity [+ stability penalty])
    dJ/dm = filter.backward( [P] (dJ/dC_g|_u + adjoint sensitivities) )

(P: the mean across a thin wall, growth.across_wall: uniform; physics/walls.py.)

(the stability penalty, optimizer.stability, joins dJ/du and dJ/dC_g|_u:
stability_penalty.py).

The gradient returned is the derivative of J with respect to the entries of m
(the Euclidean, "nodal" gradient): that is what NLopt's MMA and SLSQP use, and
the Taylor test checks.  (The L2 Riesz representative would be M^-1 times it.)

Results are cached for the last m; a new m clears the cache (the state is then
re-solved from the last equilibrium, a warm start).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass

import dolfinx.fem
import numpy as np
import ufl
from mpi4py import MPI

from .. import compat
from ..config import Config, resolved
from ..errors import StateSolveError
from ..physics.filters import HelmholtzFilter
from ..physics.model import ForwardModel
from ..physics.paths import solve_watched
from ..physics.projection import LevelProjection, grey_density
from ..physics.state import SolveReport
from ..physics.transfer import interpolate_between_meshes
from ..physics.walls import WallMean
from ..shape.clouds import assemble
from ..timing import Timer
from .adjoint import AdjointProblem
from .objective import Objective, ObjectiveValue
from .stability_penalty import StabilityPenalty

log = logging.getLogger(__name__)


@dataclass
class Evaluation:
    value: ObjectiveValue
    gradient: np.ndarray | None
    report: SolveReport


class ReducedFunctional:
    def __init__(self, model: ForwardModel, timer: Timer | None = None):
        cfg: Config = model.cfg
        self.cfg, self.model = cfg, model
        self.timer = timer or Timer()
        self.comm: MPI.Comm = model.comm
        growth = model.growth
        self.space = growth.space
        self.n_owned = self.space.dofmap.index_map.size_local
        # the filtered fields lambda_hat, theta_hat that C_g is made of, and their bounds
        eig = cfg.growth.eigenvalues
        design = resolved(eig.design)
        self.targets = [growth.eigenvalues[i - 1] for i in design] + list(growth.angles)
        # growth.levels: the designed eigenvalues projected onto the levels after the filter
        # (physics/projection.py), at the stage's sharpness; crisp (beta = inf) until a
        # driver's stage sets one, so a settled or verified design is the crisp one
        sets = cfg.growth.level_sets()
        # one projection per designed eigenvalue (its own levels, or the one list for all)
        self.projections = [LevelProjection(levels) for levels in sets] if sets else []
        self.sharpness = math.inf
        self.n_projected = len(self.projections)
        self._filtered: list[np.ndarray] = []
        self.bounds_per_field = ([(p.levels[0], p.levels[-1]) for p in self.projections]
                                 or [eig.bounds] * len(design)) + \
            [tuple(b) for b in resolved(cfg.growth.angles.bounds)[:len(growth.angles)]]
        self.names = [f"lambda_{i}" for i in design] + \
            [f"theta_{k + 1}" for k in range(len(growth.angles))]
        self.design = [dolfinx.fem.Function(self.space, name=n) for n in self.names]
        for rho, field in zip(self.design, self.targets):
            rho.x.array[:] = field.x.array  # the initial growth is the initial design
        self.filter = HelmholtzFilter(self.space, cfg.growth.filter_length,
                                      cfg.solver.petsc_options, model.state.newton.linear)
        # growth.across_wall: uniform: P after the filter (physics/walls.py), the design
        # started in P's range (a start that varies across the wall starts at its mean)
        self.wall = (WallMean(self.space, cfg.geometry.kind)
                     if cfg.growth.across_wall == "uniform" else None)
        if self.wall is not None:
            for rho in self.design:
                rho.x.array[:self.n_owned] = self.wall.apply(rho.x.array)
                rho.x.scatter_forward()
        self.objective = Objective(cfg, model.state)
        self._grey = self._grey_forms(cfg.growth.grey_penalty)
        self.adjoint = AdjointProblem(model.state)
        self.stability = (StabilityPenalty(model.state, cfg.optimizer.stability)
                          if cfg.optimizer.stability.min_eigenvalue is not None else None)
        self._indices = [growth.fields.index(f) for f in self.targets]
        self._key: bytes | None = None
        self._last: Evaluation | None = None
        self._report: SolveReport | None = None  # the state solve of the design ``_key``
        self.evaluations = 0

    def _grey_forms(self, weight: float) -> tuple[dolfinx.fem.Form, list] | None:
        """growth.grey_penalty: w s D (physics/projection.py, grey_density) over the projected
        fields, D their mean over the body and the fields, s the target's size (J is a
        length), and its derivative by each."""
        if not weight or not self.projections:
            return None
        mesh = self.space.mesh
        # D is quadratic in the fields: exact at twice their degree (two levels)
        dx = ufl.dx(domain=mesh, metadata={
            "quadrature_degree": 2 * compat.space_degree(self.space)})
        volume = mesh.comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(
            1.0 * dx)), MPI.SUM)
        scale = weight * self.objective.target_size / (volume * len(self.projections))
        density = sum(grey_density(f, p.levels)
                      for f, p in zip(self.targets, self.projections))
        value = scale * density * dx
        return dolfinx.fem.form(value), [dolfinx.fem.form(ufl.derivative(value, f))
                                         for f in self.targets[:self.n_projected]]

    # ---- the design vector -----------------------------------------------------------------
    @property
    def size(self) -> int:
        return self.n_owned * len(self.design)

    def current(self) -> np.ndarray:
        return np.concatenate([rho.x.array[:self.n_owned] for rho in self.design])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.concatenate([np.full(self.n_owned, b[0]) for b in self.bounds_per_field])
        hi = np.concatenate([np.full(self.n_owned, b[1]) for b in self.bounds_per_field])
        return lo, hi

    def _apply(self, m: np.ndarray) -> None:
        with self.timer("filter"):
            for k, (rho, field) in enumerate(zip(self.design, self.targets)):
                rho.x.array[:self.n_owned] = m[k * self.n_owned:(k + 1) * self.n_owned]
                rho.x.scatter_forward()
                self.filter.forward(rho, field)
                if self.wall is not None:
                    field.x.array[:self.n_owned] = self.wall.apply(field.x.array)
                    field.x.scatter_forward()
            if self.projections:  # kept for the chain rule and a new sharpness
                self._filtered = [f.x.array.copy() for f in self.targets[:self.n_projected]]
                self._project()

    def _project(self) -> None:
        """growth.levels: the kept filtered eigenvalues projected at the current sharpness;
        every local entry, ghosts included, is nodal."""
        for field, x, projection in zip(self.targets, self._filtered, self.projections):
            field.x.array[:] = projection.value(x, self.sharpness)

    def level_fields(self) -> tuple[list[str], list[dolfinx.fem.Function],
                                    list[dolfinx.fem.Function]]:
        """growth.levels: the designed eigenvalues' names, their fields as applied (at the
        current sharpness; crisp once settled) and the same after the filter, before the
        projection (the design the crisp one rounds)."""
        assert self.projections, "growth.levels is not set"
        filtered = []
        for field, x in zip(self.targets, self._filtered):
            f = dolfinx.fem.Function(self.space, name=f"{field.name}_filtered")
            f.x.array[:] = x
            filtered.append(f)
        n = self.n_projected
        return self.names[:n], self.targets[:n], filtered

    def set_sharpness(self, beta: float) -> None:
        """One stage of growth.sharpness (math.inf: the crisp design): the growth changes with
        it, so the state is solved again (from the last equilibrium) at the next evaluation."""
        if not self.projections or beta == self.sharpness:
            return
        self.sharpness = beta
        self._project()
        self._forget()

    # ---- J and dJ/dm -----------------------------------------------------------------------
    def evaluate(self, m: np.ndarray, gradient: bool = True) -> Evaluation:
        m = np.ascontiguousarray(m, dtype=float)
        key = m.tobytes()
        # m is this rank's share: a design may change on one rank and not on another (the
        # first evaluation of an alpha stage at the best design of the last one: the ranks
        # disagreed and deadlocked in different collectives).  Whether it is the cached
        # design is decided by all ranks together; the cache itself is set collectively.
        same = self.comm.allreduce(key == self._key, MPI.LAND)
        if same and self._last is not None and (
                self._last.gradient is not None or not gradient):
            return self._last
        if not same or self._report is None:
            self._apply(m)
            with self.timer("forward"):
                report = self._solve_state()
            if not report.converged:
                self._forget()
                raise StateSolveError(report)
            self._report = report
        else:
            report = self._report  # the state is this design's: only J (and dJ) are new
        self.evaluations += 1
        with self.timer("hausdorff"):
            value, dJdu = self.objective.evaluate(gradient)
        if self.stability is not None:
            with self.timer("forward", "stability"):
                penalty = self.stability.value()
            value = dataclasses.replace(
                value, total=value.total + penalty, stability=penalty,
                lowest_eigenvalue=self.stability.lowest[0] if self.stability.lowest else None)
        if self._grey is not None:
            grey = self.comm.allreduce(dolfinx.fem.assemble_scalar(self._grey[0]), MPI.SUM)
            value = dataclasses.replace(value, total=value.total + grey, grey=grey)
        grad = None
        if gradient:
            grad = self._gradient(dJdu)
        self._key, self._last = key, Evaluation(value, grad, report)
        return self._last

    def restart_from_rest(self, step_scale: float = 1.0) -> None:
        """The next evaluation solves its state from rest (load steps from C_g = I, the first
        one ``step_scale`` times the configured), even for the design evaluated last: the
        state and the cached evaluation are both dropped."""
        self.model.state.reset(step_scale)
        self._forget()

    def state_snapshot(self) -> np.ndarray:
        """The state's owned displacement DOFs (for a checkpoint)."""
        return self.model.state.snapshot()

    def restore(self, m: np.ndarray, state: np.ndarray) -> None:
        """Design ``m`` with ``state`` (a :meth:`state_snapshot`) as its equilibrium: a
        resumed run continues exactly where the interrupted one was."""
        self._apply(np.ascontiguousarray(m, dtype=float))
        self.model.state.restore(state)
        self._forget()

    def carry_design(self, source: ReducedFunctional, m: np.ndarray) -> None:
        """Take ``source``'s design ``m`` as this functional's current design: each design
        field interpolated onto this mesh (exact on a nested refinement of source's mesh;
        collective).  The next evaluation applies it, its state solved from source's last
        equilibrium carried onto this mesh (the branch the last level followed; from rest
        where that fails)."""
        for k, (rho, mine) in enumerate(zip(source.design, self.design)):
            rho.x.array[:source.n_owned] = m[k * source.n_owned:(k + 1) * source.n_owned]
            rho.x.scatter_forward()
            interpolate_between_meshes(rho, mine)
        self.model.state.carry(source.model.state.u)
        self._forget()

    @property
    def target_points(self) -> np.ndarray:
        """This rank's points of the target cloud."""
        return self.objective.target.points

    @property
    def target_size(self) -> float:
        """The target's largest extent (its sample points, as rho_H sees them)."""
        return self.objective.target_size

    def exact_hausdorff(self) -> float:
        """The exact Hausdorff distance between the deformed body as it is and the target."""
        return self.objective.exact_hausdorff()

    def value_from_rest(self) -> tuple[ObjectiveValue | None, SolveReport]:
        """The objective at the current growth grown again from rest (load steps from
        C_g = I), or None where that finds no equilibrium, with the solve's report.  The
        optimiser reaches its equilibria by warm starts along its own path; a thin body can
        have several, and the one reached from rest is what growing the body with this growth
        does.  The optimiser's state is put back afterwards."""
        state = self.model.state
        kept = state.snapshot()
        state.reset()
        try:
            report = self._solve_state()
            value = self.objective.evaluate(gradient=False)[0] if report.converged else None
        finally:
            state.restore(kept)
        return value, report

    def _solve_state(self) -> SolveReport:
        """The state's solve; from rest (a run's first evaluation, a retry, a level's start
        where the carried state finds no equilibrium, the check from rest) its path is
        watched and, with ``solver.branch: switch``, left where it loses stability, as the
        verification's is: a growth then reaches one equilibrium from rest in the run and
        in its verification.  Measured on scene 4's solid cone: the second level's start,
        its carried cone lost, grew the unwatched state from rest into the mirror cone (J
        0.74 against 2.4e-3) where the watched path switches onto the cone (SCENES.md,
        'Scene 4')."""
        state = self.model.state
        if state.at_rest and self.cfg.solver.branch == "switch":
            return solve_watched(state, "switch")[0]
        return state.solve()

    def set_warm_rtol(self, rtol: float | None) -> None:
        """Newton's relative tolerance for the state solves of the next designs (warm steps
        from the last equilibrium; None: solver.rtol).  Solves from rest keep solver.rtol."""
        self.model.state.warm_rtol = rtol

    def stopping_scale(self) -> float:
        """The scale of J's progress for Newton's tolerance along the run (0: |J| alone; see
        Objective): rho_H(T, T) at the current alpha, a pair sum (timed as rho_H's)."""
        with self.timer("hausdorff"):
            return self.objective.stopping_scale()

    def _forget(self) -> None:
        self._key, self._last, self._report = None, None, None

    def set_alpha(self, alpha: float) -> None:
        """One stage of an alpha schedule: J changes, the state does not (the cached
        equilibrium is kept, the cached J and dJ are dropped)."""
        if alpha != self.objective.alpha:
            self.objective.set_alpha(alpha)
            self._last = None

    def _gradient(self, dJdu) -> np.ndarray:
        penalty = self.stability if self.stability is not None and \
            self.stability.active() else None
        dJdw = None
        if penalty is not None:
            with self.timer("adjoint", "stability"):
                dJdw = penalty.derivative_w()
        with self.timer("adjoint", "adjoint_solve"):
            self.adjoint.solve(dJdu, dJdw)
        with self.timer("adjoint", "sensitivities"):
            sens = self.adjoint.sensitivities()
            explicit = self.objective.explicit_growth_derivatives()
            if explicit is not None:
                for s, e in zip(sens, explicit):
                    s.axpy(1.0, e)
            if penalty is not None:
                for s, e in zip(sens, penalty.derivatives_growth()):
                    s.axpy(1.0, e)
        parts = []
        with self.timer("filter", "filter_backward"):
            for k, i in enumerate(self._indices):
                dual = sens[i]
                if k < self.n_projected:  # dP/dx, nodal
                    dual = sens[i].copy()
                    if self._grey is not None:  # growth.grey_penalty: d(w D)/dp
                        dual.axpy(1.0, assemble(self._grey[1][k]))
                    dual.array[:self.n_owned] *= self.projections[k].slope(
                        self._filtered[k][:self.n_owned], self.sharpness)
                if self.wall is not None:  # P is symmetric: dJ/df P
                    walled = dual.copy()
                    walled.array[:self.n_owned] = self.wall.apply(dual.array)
                    dual = walled
                out = sens[i].duplicate()
                self.filter.backward(dual, out)
                parts.append(out.array[:self.n_owned].copy())
        return np.concatenate(parts) if parts else np.zeros(0)

    def __call__(self, m: np.ndarray) -> float:
        return self.evaluate(m, gradient=False).value.total

    def gradient(self, m: np.ndarray) -> np.ndarray:
        grad = self.evaluate(m, gradient=True).gradient
        assert grad is not None  # asked for
        return grad

    def dot(self, a: np.ndarray, b: np.ndarray) -> float:
        """Euclidean inner product of two distributed design vectors."""
        return self.comm.allreduce(float(np.dot(a, b)), MPI.SUM)

    def design_coordinates(self) -> np.ndarray:
        """Coordinates of the owned design DOFs, repeated per field (for smooth directions)."""
        x = self.space.tabulate_dof_coordinates()[:self.n_owned]
        return np.concatenate([x] * len(self.design))
