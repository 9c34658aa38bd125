"""A growth shell's reduced functional J(m) = S(wall(m), target), S rho_H or rho_H debiased
(shape/divergence.py), as the optimisation
driver sees it (:class:`optim.interface.DesignProblem`): m the owned entries of the shell's
design Function, or the raw fields the Helmholtz filter (5.7) makes it of, each field
bounded; the state the shell's equilibrium (from the last one, physics/shell.py); dJ/dm by
the shell's adjoint (optim/shell_objective.py) and the filter's transpose."""

from __future__ import annotations

from collections.abc import Sequence

import dolfinx.fem
import numpy as np
from mpi4py import MPI

from .. import compat
from ..errors import StateSolveError
from ..physics.filters import HelmholtzFilter
from ..physics.shell import GrowthShell
from ..physics.state import SolveReport
from ..shape.divergence import ShapeDivergence
from ..shape.hausdorff import PointCloud, SmoothHausdorff
from ..timing import Timer
from .objective import ObjectiveValue
from .problem import Evaluation
from .shell_objective import ShellCloud


class ShellDesign:
    """J(m) of ``shell`` (built with a design) against ``target`` (this rank's share of the
    target's cloud) with ``rho``; ``lower`` and ``upper``: each design field's bounds;
    ``filter_length``: the Helmholtz filter's l (0: the design is m itself).  The last
    evaluation is kept: the same m again is answered without solving."""

    def __init__(self, shell: GrowthShell, target: PointCloud, rho: SmoothHausdorff,
                 lower: Sequence[float], upper: Sequence[float], cloud: ShellCloud | None = None,
                 filter_length: float = 0.0, form: str = "paper",
                 fixed: Sequence[int] = (), timer: Timer | None = None):
        if shell.design is None:
            raise ValueError("the shell was built without a design: nothing to optimise")
        self.shell, self.target = shell, target
        self.cloud = ShellCloud(shell) if cloud is None else cloud
        self.comm: MPI.Comm = shell.mesh.comm
        self.design = shell.design
        dofmap = self.design.function_space.dofmap
        self.fields = dofmap.index_map_bs
        if len(lower) != self.fields or len(upper) != self.fields:
            raise ValueError(f"one bound per design field ({self.fields}): lower {lower}, "
                             f"upper {upper}")
        self.n_owned = dofmap.index_map.size_local * self.fields
        self.lower = np.tile(np.asarray(lower, dtype=float), self.n_owned // self.fields)
        self.upper = np.tile(np.asarray(upper, dtype=float), self.n_owned // self.fields)
        for field in fixed:  # held where they start: their bounds at their values
            if not 0 <= field < self.fields:
                raise ValueError(f"fixed field {field}: the design has {self.fields}")
            here = self.design.x.array[field:self.n_owned:self.fields]
            self.lower[field::self.fields] = here
            self.upper[field::self.fields] = here
        # the shape term (rho_H itself, "paper", or debiased), kept from one evaluation to
        # the next: a debiased one computes rho_H(T, T) once per alpha, not per evaluation
        self.divergence = ShapeDivergence(rho, form)
        self.timer = timer if timer is not None else Timer()
        self._last: tuple[bytes, Evaluation] | None = None
        space = self.design.function_space
        self.filter = HelmholtzFilter(space, filter_length)
        self.raw = dolfinx.fem.Function(space)  # m, the optimiser's variable
        self.raw.x.array[:] = self.design.x.array
        self._dual = dolfinx.fem.Function(space)

    @property
    def size(self) -> int:
        return self.n_owned

    def current(self) -> np.ndarray:
        return self.raw.x.array[:self.n_owned].copy()

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.lower.copy(), self.upper.copy()

    def evaluate(self, m: np.ndarray, gradient: bool = True) -> Evaluation:
        key = np.ascontiguousarray(m, dtype=float).tobytes()
        if self._last is not None and self._last[0] == key and (
                self._last[1].gradient is not None or not gradient):
            return self._last[1]
        self.raw.x.array[:self.n_owned] = m
        self.raw.x.scatter_forward()
        with self.timer("filter"):
            self.filter.forward(self.raw, self.design)
        with self.timer("forward"):
            solved = self.shell.solve()
        report = SolveReport(converged=solved.converged, steps=solved.steps,
                             failed_steps=solved.failed_steps,
                             newton_iterations=solved.newton_iterations, reached=solved.level,
                             reason="" if solved.converged else
                             f"the shell reached {solved.level:.4g} of the growth")
        if not solved.converged:
            raise StateSolveError(report)
        with self.timer("hausdorff"):  # and the shell's adjoint, where gradient
            term, dJ = self.cloud.shape_term(self.target, self.divergence, gradient)
        result = term.pair
        value = ObjectiveValue(total=term.value, rho_H=result.value, complexity=0.0,
                               d_target_to_body=result.d_target_to_body,
                               d_body_to_target=result.d_body_to_target,
                               hausdorff=result.hausdorff, shape=term.value,
                               alpha=self.rho.alpha)
        dm = None
        if dJ is not None:  # dJ/dm_hat carried back through the filter to m
            with self.timer("filter"):
                self.filter.backward(compat.petsc_vec(dJ), compat.petsc_vec(self._dual))
            dm = self._dual.x.array[:self.n_owned].copy()
        evaluation = Evaluation(value, dm, report)
        self._last = (key, evaluation)
        return evaluation

    @property
    def rho(self) -> SmoothHausdorff:
        """rho_H of (2.9) at the current alpha."""
        return self.divergence.rho

    def set_alpha(self, alpha: float) -> None:
        if alpha != self.rho.alpha:
            self.divergence = self.divergence.with_alpha(alpha)
            self._last = None

    def set_sharpness(self, beta: float) -> None:
        """The shell's design has no levels (growth.levels): only the crisp stage."""
        if np.isfinite(beta):
            raise ValueError("a shell's design has no growth levels to sharpen")

    def stopping_scale(self) -> float:
        """rho_H(T, T) at the current alpha: the scale of J's progress."""
        return float(self.rho(self.target, self.target, self.comm, gradient=False).value)
