"""The state: hyperelastic equilibrium under growth, Dirichlet data and loads.

The total energy (2.8) is
    Pi(u) = int psi(F, C_g) dX - int f . u dX - sum_k int_{Gamma_k} s0_k . u dS,
its first variation is the residual (5.10)-(5.11) and its second the tangent
(5.12); both come from ``ufl.derivative``.  PETSc SNES (newton.py, options prefix
``state_``) solves R(u) = 0 by Newton's method with MUMPS by default.

Growth is reached by continuation: the growth applied to the body moves from
the last equilibrium (or from C_g = I at rest) to the requested one in steps
that double after easy Newton solves and halve after a failed one, until the
step falls below ``solver.continuation.min_step``.  Each step starts from the
secant extrapolation of the last two equilibria (on the half-circle bend of
the scene-1 beam this halves the Newton iterations: 69 instead of 130).  The
last converged state is always kept.  The steps before the full growth only
start the next one: with ``solver.continuation.step_rtol`` set (opt-in), Newton
stops there at it, the last step at ``solver.rtol``, and after a failed step the
halved size is kept for ``HOLD_AFTER_CUT`` steps before it may double again.
Not the default: at 1e-4 a notebook's cup (disk_cone, h 0.2, one layer) found no
equilibrium beyond 0.9 of its growth, which it reaches with tight steps.  Measured on
the scenes' optima grown from rest on their own meshes: the Newton iterations
fall by 8-54 % (tube 184 -> 134, 3D ring 268 -> 124, 3D beam 53 -> 31, disk
76 -> 70, flare 43 -> 34), every shape error the same to four digits
(docs/PERFORMANCE.md, "Continuation from rest").

An optimiser's step (a warm solve from the last equilibrium) starts from a first-order
predictor instead: du = -K^-1 R(u; C_g new) ~ -K^-1 dR/dC_g dC_g, with K the tangent the
last Newton step factored (the factors the adjoint reuses), repeated as chord steps while
each at least halves the residual (``solver.chord_steps`` at most, each a back-substitution
and a residual assembly instead of a factorisation).  Newton then
stops at the residual it would have stopped at without the predictor (``rtol`` of the
residual at the last equilibrium under the new growth, or ``atol``), so the predictor
changes the cost, not the accuracy.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from .. import compat
from ..config import Config, resolved
from . import linear
from .boundary import clamp_conditions, fixed_conditions
from .geometry import Domain
from .growth import Growth
from .kinematics import Kinematics
from .material import deformation_gradient, material_of
from .newton import NewtonSolver
from .pressure import pressure_energy
from .transfer import interpolate_between_meshes

log = logging.getLogger(__name__)

# after a failed load step, this many converged steps at the halved size before it may
# double again (without it a step that converges easily at s and fails at 2 s is tried at
# 2 s after every success)
HOLD_AFTER_CUT = 2

_INSERT, _ADD = PETSc.InsertMode.INSERT, PETSc.InsertMode.ADD
_FORWARD, _REVERSE = PETSc.ScatterMode.FORWARD, PETSc.ScatterMode.REVERSE


@dataclass
class SolveReport:
    """What one call of :meth:`StateProblem.solve` did."""

    converged: bool = True
    reason: str = ""
    steps: int = 0
    failed_steps: int = 0
    newton_iterations: int = 0
    chord_steps: int = 0  # predictor steps on the last factors (no factorisation)
    shifted_steps: int = 0  # a carried start's fallback (paths.solve_watched), where taken
    reached: float = 1.0  # fraction of the requested growth change in equilibrium
    seconds: float = 0.0
    history: list[tuple[float, int]] = field(default_factory=list)  # (t, iterations)


class StateProblem:
    """u such that R(u; C_g) = 0, for the growth held in ``self.target``."""

    role = "state_"  # the prefix of this solver's keys in solver.petsc_options

    def __init__(self, domain: Domain, cfg: Config, growth: Growth):
        self.domain, self.cfg, self.target = domain, cfg, growth
        mesh = domain.mesh
        self.dim = mesh.geometry.dim
        m = cfg.material
        self.mixed = m.formulation == "mixed"
        self.incompressible = bool(m.incompressible)
        # the unknown w of Newton's method in its space W: the displacement u itself, or
        # (u, p) of the mixed formulation, u then kept as a copy (sync) for the rest of the code
        if self.mixed:
            self.W = compat.mixed_space(mesh, cfg.model.degree)
            self.w = dolfinx.fem.Function(self.W, name="state")
            self.V, u_dofs = self.W.sub(0).collapse()
            self._u_dofs = np.asarray(u_dofs, dtype=np.int32).ravel()  # 0.11: a list of one
            self.u = dolfinx.fem.Function(self.V, name="displacement")
            self._disp, self._pressure = ufl.split(self.w)
            sub = self.W.sub(0)
        else:
            self.V = compat.vector_space(mesh, cfg.model.degree)
            self.u = dolfinx.fem.Function(self.V, name="displacement")
            self.W, self.w = self.V, self.u
            self._disp, self._pressure = self.u, None
            sub = self.V
        self._scratch: dolfinx.fem.Function | None = None  # a vector of W (displacement_of)
        self.applied = growth.like()  # the growth that self.u is in equilibrium with
        self.material = material_of(cfg)
        self.kinematics = Kinematics(cfg.section, mesh, self.material, self.incompressible)
        self.weight = self.kinematics.weight()  # 2 pi R for a body of revolution, else 1
        self.load_scale = compat.constant(mesh, 1.0)

        metadata = {"quadrature_degree": cfg.quadrature_degree}
        self.dx = ufl.Measure("dx", domain=mesh, metadata=metadata)
        self.metadata = metadata
        self.energy = self._energy()
        self.v, du = ufl.TestFunction(self.W), ufl.TrialFunction(self.W)
        self.residual_ufl = ufl.derivative(self.energy, self.w, self.v)
        self.jacobian_ufl = ufl.derivative(self.residual_ufl, self.w, du)
        self.residual_form = dolfinx.fem.form(self.residual_ufl)
        self.jacobian_form = dolfinx.fem.form(self.jacobian_ufl)
        self.bcs = clamp_conditions(sub, domain, cfg.boundary.clamp,
                                    cfg.section.axisymmetric, collapsed=self.V) + \
            fixed_conditions(sub, domain, cfg.boundary.fix, cfg.section.axes)

        self.A = dolfinx.fem.petsc.create_matrix(self.jacobian_form)
        self.b = compat.create_vector(self.residual_form)
        self._chord_b = compat.create_vector(self.residual_form)
        self._chord_du = self.A.createVecRight()
        self.newton = NewtonSolver(self.role, self, cfg, self.force_scale(), self.A, self.b)
        self.jacobian_assemblies = 0  # the SNES's linear solver holds factors once this is > 0
        # Newton's relative tolerance for the next warm step (an optimiser's step from the
        # last equilibrium); None: solver.rtol.  Solves from rest always use solver.rtol.
        self.warm_rtol: float | None = None
        self._at_rest = True
        self._equilibrium: list[np.ndarray] | None = None  # growth values of the last equilibrium
        self._first_step_scale = 1.0  # a retry from rest may ask for smaller first steps
        self._det_F = self._det_F_sampler(max(cfg.quadrature_degree,
                                              cfg.objective.hausdorff.quadrature_degree))

    def sync(self) -> None:
        """The displacement ``u`` from the unknown ``w`` (the mixed formulation's; nothing to
        do for the displacement alone): after every change of ``w``."""
        if self.mixed:
            self.w.x.scatter_forward()
            self.u.x.array[:] = self.w.x.array[self._u_dofs]

    def to_unknown(self, vec_u: PETSc.Vec, vec_w: PETSc.Vec) -> None:
        """A vector of the displacement's DOFs (e.g. dJ/du) into ``vec_w`` of the unknown's,
        zero in the pressure's (owned entries; a copy for the displacement alone)."""
        if not self.mixed:
            vec_u.copy(vec_w)
            return
        owned = self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs
        vec_w.zeroEntries()
        target = vec_w.getArray()
        target[self._u_dofs[:owned]] = vec_u.getArray(readonly=True)[:owned]
        vec_w.setArray(target)

    def displacement_of(self, vec_w: PETSc.Vec, target: dolfinx.fem.Function) -> None:
        """The displacement's part of a vector of the unknown's DOFs (e.g. an eigenvector of
        the tangent) into ``target``, a function on ``V``, ghosts updated (collective)."""
        if not self.mixed:
            vec_w.copy(compat.petsc_vec(target))
            target.x.scatter_forward()
            return
        if self._scratch is None:
            self._scratch = dolfinx.fem.Function(self.W)
        vec_w.copy(compat.petsc_vec(self._scratch))
        self._scratch.x.scatter_forward()
        target.x.array[:] = self._scratch.x.array[self._u_dofs]

    # ---- the model -------------------------------------------------------------------------
    def deformation_gradient(self) -> ufl.core.expr.Expr:
        return deformation_gradient(self._disp)

    def energy_density(self, F: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """psi of (5.1) per unit reference volume at the mesh's deformation gradient F (with
        the pressure of the mixed formulation)."""
        if self._pressure is not None:
            return self.kinematics.psi_mixed(F, self._disp, self.applied.tensor(),
                                             self._pressure, self.incompressible)
        return self.kinematics.psi(F, self._disp, self.applied.tensor())

    def _energy(self) -> ufl.Form:
        w = self.weight
        energy = self.energy_density(self.deformation_gradient()) * w * self.dx
        loads = self.cfg.loads
        axes = list(self.cfg.section.axes)  # a section's loads are the 3D body's
        body_force = resolved(loads.body_force)
        if any(body_force):
            f = dolfinx.fem.Constant(self.domain.mesh, np.array(body_force, dtype=float)[axes])
            energy -= self.load_scale * ufl.dot(f, self._disp) * w * self.dx
        for name, vec in loads.traction.items():
            if any(vec):
                s0 = dolfinx.fem.Constant(self.domain.mesh, np.array(vec, dtype=float)[axes])
                energy -= self.load_scale * ufl.dot(s0, self._disp) * w * \
                    self.domain.ds(name, self.metadata)
        pressure = pressure_energy(self.domain, self.cfg, self._disp, self.metadata,
                                   self.load_scale)
        return energy if pressure is None else energy + pressure

    def first_piola(self) -> ufl.core.expr.Expr:
        """P = dpsi/dF at the current state (the mesh's components, dim x dim)."""
        F = ufl.variable(self.deformation_gradient())
        return ufl.diff(self.energy_density(F), F)

    def volume_ratio(self) -> ufl.core.expr.Expr:
        """Deformed per reference measure (det F; times the hoop stretch for a body of
        revolution)."""
        return self.kinematics.volume_ratio(self.deformation_gradient(), self._disp)

    def force_scale(self) -> float:
        """The material's stress scale (mu1 + mu2 + lambda for the paper's) times
        |body|^((d-1)/d): a stress times a cross-section."""
        mesh = self.domain.mesh
        one = compat.constant(mesh, 1.0)
        volume = mesh.comm.allreduce(dolfinx.fem.assemble_scalar(
            dolfinx.fem.form(one * self.weight * ufl.dx(domain=mesh))), MPI.SUM)
        dim = 3 if self.cfg.section.axisymmetric else self.dim  # the weighted measure's
        return self.material.modulus * volume ** ((dim - 1) / dim)

    def _det_F_sampler(self, degree: int):
        """det F at the quadrature points of ``degree`` on the owned cells."""
        mesh = self.domain.mesh
        points, _ = compat.reference_quadrature(mesh, degree)
        cells = np.arange(mesh.topology.index_map(mesh.topology.dim).size_local, dtype=np.int32)
        return compat.expression_evaluator(self.volume_ratio(), points, mesh, cells)

    def inverted_points(self) -> int:
        """How many sample points of the current state have det F <= 0 (all ranks)."""
        local = int(np.count_nonzero(~(self._det_F() > 0.0)))  # NaN counts as inverted
        return self.domain.mesh.comm.allreduce(local, MPI.SUM)

    def assemble_residual(self, x: PETSc.Vec, b: PETSc.Vec) -> None:
        """R(x) into ``b``, with the Dirichlet rows set to x - g (SNES's residual)."""
        x.ghostUpdate(addv=_INSERT, mode=_FORWARD)
        w = compat.petsc_vec(self.w)
        x.copy(w)
        w.ghostUpdate(addv=_INSERT, mode=_FORWARD)
        with b.localForm() as b_local:
            b_local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, self.residual_form)
        compat.apply_lifting(b, [self.jacobian_form], [self.bcs], [x], alpha=-1.0)
        b.ghostUpdate(addv=_ADD, mode=_REVERSE)
        compat.set_bc(b, self.bcs, x, alpha=-1.0)

    def assemble_tangent(self, x: PETSc.Vec, A: PETSc.Mat) -> None:
        """The tangent (5.12) at the current ``u`` into ``A`` (SNES's Jacobian, counted:
        the SNES's linear solver holds factors once one was assembled)."""
        self.tangent_into(A)
        self.jacobian_assemblies += 1

    def tangent_into(self, A: PETSc.Mat) -> None:
        """The tangent (5.12) at the current ``u`` into ``A``, the clamped rows and columns
        those of the identity (for the adjoint's and the stability's own matrices)."""
        A.zeroEntries()
        # dolfinx 0.5's annotations miss this (singledispatch) overload
        dolfinx.fem.petsc.assemble_matrix(A, self.jacobian_form, bcs=self.bcs)
        A.assemble()

    chord_contraction = 0.5  # a chord step must halve the residual to go on

    def _chord(self) -> tuple[float, int]:
        """The predictor: chord steps u -= K_old^-1 R(u) on the state solver's last factors
        while each leaves at most ``chord_contraction`` of the residual; a step that does not
        reduce it is undone.  Returns the residual norm before the first step (the reference
        of Newton's relative tolerance) and the steps kept (collective)."""
        x, b, du = compat.petsc_vec(self.w), self._chord_b, self._chord_du
        ksp = self.newton.snes.getKSP()
        self.assemble_residual(x, b)
        r0 = previous = b.norm()
        target = max(self._warm_rtol() * r0, self.newton.snes.getTolerances()[1])
        kept = 0
        with self.newton.options.pushed():
            for _ in range(self.cfg.solver.chord_steps):
                if previous <= target:
                    break
                ksp.solve(b, du)
                if linear.reason_of(ksp) < 0:
                    break
                x.axpy(-1.0, du)
                x.ghostUpdate(addv=_INSERT, mode=_FORWARD)
                self.assemble_residual(x, b)
                r = b.norm()
                if not np.isfinite(r) or r >= previous:  # undo it
                    x.axpy(1.0, du)
                    x.ghostUpdate(addv=_INSERT, mode=_FORWARD)
                    break
                kept += 1
                contraction, previous = r / previous, r
                if contraction > self.chord_contraction:
                    break
        self.w.x.scatter_forward()
        return r0, kept

    def _warm_rtol(self) -> float:
        return self.cfg.solver.rtol if self.warm_rtol is None else self.warm_rtol

    def equilibrate(self) -> tuple[bool, int, str]:
        """Newton's method from the current displacement under the growth applied now (a
        state moved off its equilibrium, e.g. onto another branch): converged, iterations,
        reason."""
        result = self.newton.solve()
        self.sync()
        return result

    # ---- continuation ----------------------------------------------------------------------
    # The state's lifecycle: at rest (after construction or ``reset``), in equilibrium with
    # the growth ``target`` held at the last ``solve``; ``snapshot``/``restore`` keep and put
    # back an equilibrium (a run's final check from rest, a resumed run).
    @property
    def at_rest(self) -> bool:
        """Whether the next solve starts from rest (load steps from C_g = I)."""
        return self._at_rest

    @property
    def carried(self) -> bool:
        """Whether the next solve starts from a carried guess (:meth:`carry`): Newton at the
        full growth from a state that is no equilibrium of this mesh."""
        return not self._at_rest and self._equilibrium is None

    def reset(self, step_scale: float = 1.0) -> None:
        """Forget the equilibrium: the next solve starts from rest, its first load step
        ``step_scale`` times ``solver.continuation.initial_step``."""
        self.w.x.array[:] = 0.0
        self.sync()
        self._at_rest = True
        self._equilibrium = None
        self._first_step_scale = step_scale

    def carry(self, source: dolfinx.fem.Function) -> None:
        """Start the next solve from the displacement ``source`` of another mesh of this
        body (a coarser level's equilibrium, exact on a nested refinement): Newton at the
        full growth from there, no load steps.  Where it does not converge the solve reports
        so at once (the driver then retries from rest; a check continued onto a finer mesh
        takes shifted Newton steps from it: paths.solve_watched).  Measured on scene 4's
        section: from rest, the second level's growth found no equilibrium beyond 3.6 % of it
        (the flat disk's bifurcation), while the first level's optimum is a buckled cone
        already."""
        interpolate_between_meshes(source, self.u)
        self.u.x.scatter_forward()
        if self.mixed:  # the displacement carried; the pressure from rest (zero)
            self.w.x.array[:] = 0.0
            self.w.x.array[self._u_dofs] = self.u.x.array
        self._at_rest = False
        self._equilibrium = None  # solve: a carried guess, not an equilibrium

    def snapshot(self) -> np.ndarray:
        """A copy of the owned DOFs of the unknown (the displacement, and the mixed
        formulation's pressure)."""
        n = self.W.dofmap.index_map.size_local * self.W.dofmap.index_map_bs
        return self.w.x.array[:n].copy()

    def put_back(self, owned: np.ndarray) -> None:
        """The unknown's owned DOFs set to ``owned`` (a :meth:`snapshot`), the equilibrium's
        bookkeeping untouched."""
        self.w.x.array[:len(owned)] = owned
        self.w.x.scatter_forward()
        self.sync()

    def restore(self, owned: np.ndarray) -> None:
        """Take the displacement ``owned`` (a :meth:`snapshot`) as the equilibrium of the
        growth ``target`` now holds."""
        self.put_back(owned)
        self.applied.assign(self.target.values())
        self.load_scale.value = 1.0
        self._equilibrium = self.target.values()
        self._at_rest = False

    def solve(self, watch: Callable[[float], bool] | None = None) -> SolveReport:
        """Bring ``self.u`` into equilibrium with ``self.target``'s growth; ``watch`` is
        called with the load fraction after each converged load step, and returns True where
        it moved the state to another equilibrium at that load (paths.py)."""
        cont = self.cfg.solver.continuation
        report = SolveReport()
        tic = time.perf_counter()
        end = self.target.values()
        if self._at_rest:
            start, scale0 = self.target.identity_values(), 0.0
            dt = cont.initial_step * self._first_step_scale
            self._first_step_scale = 1.0
        elif self._equilibrium is None:  # carried (carry): Newton at the full growth
            start, scale0, dt = end, 1.0, 1.0
        else:
            start, scale0, dt = self._equilibrium, 1.0, 1.0
        carried = self.carried
        # progress per load step from rest or from a carried state (a level's first solve, a
        # continued check); warm re-solves (optimisation) only in --verbose
        level = logging.INFO if self._at_rest or carried else logging.DEBUG
        t = 0.0
        saved = self.w.x.array.copy()
        previous: tuple[float, np.ndarray] | None = None  # the equilibrium before `saved`
        hold = 0  # converged steps still to make at the size a failure cut to
        while t < 1.0 - 1e-14:
            dt = min(dt, 1.0 - t)
            trial = t + dt
            self.applied.assign(self.applied.blend(start, end, trial))
            self.load_scale.value = scale0 + trial * (1.0 - scale0)
            first_at_full = scale0 == 1.0 and t == 0.0  # from an equilibrium or a carry
            reference = None
            rtol = self._warm_rtol() if first_at_full and not carried else None  # warm
            if rtol is None and trial < 1.0 - 1e-14:  # an intermediate load step
                rtol = cont.step_rtol
            if previous is not None:  # secant predictor along the equilibrium path
                t_prev, u_prev = previous
                self.w.x.array[:] = saved + (trial - t) / (t - t_prev) * (saved - u_prev)
            elif first_at_full and self.cfg.solver.chord_steps and \
                    self.jacobian_assemblies > 0:  # a warm step: the tangent predictor
                reference, chords = self._chord()
                report.chord_steps += chords
            ok, its, reason = self.newton.solve(reference, rtol)
            self.sync()
            report.newton_iterations += its
            if ok:
                previous = (t, saved.copy())
                t = trial
                saved[:] = self.w.x.array
                report.steps += 1
                report.history.append((t, its))
                log.log(level, "  load step %3d: t = %.4f (step %.3g), %2d Newton iterations",
                        report.steps, t, dt, its)
                if watch is not None and watch(t):  # moved onto another branch at t
                    saved[:] = self.w.x.array
                    previous = None
                if hold > 0:
                    hold -= 1
                elif its <= 5:
                    dt *= 2.0
                continue
            report.failed_steps += 1
            self.w.x.array[:] = saved
            self.sync()
            if carried:  # smaller steps toward the same growth cannot help
                log.log(level, "  Newton's method from the carried state failed (%s after %d "
                        "iterations)", reason, its)
                report.converged = False
                report.reason = f"no equilibrium near the carried state ({reason})"
                break
            dt /= 2.0
            hold = HOLD_AFTER_CUT if cont.step_rtol is not None else 0
            log.log(level, "  load step at t = %.4f failed (%s after %d iterations): "
                    "step cut to %.3g", trial, reason, its, dt)
            if dt < cont.min_step or report.steps + report.failed_steps >= cont.max_steps:
                report.converged = False
                report.reason = f"no equilibrium beyond {t:.4f} of the growth ({reason})"
                break
        # Keep the state and the growth it balances consistent, whatever happened.
        reached = self.applied.blend(start, end, t)
        self.applied.assign(reached)
        self.load_scale.value = scale0 + t * (1.0 - scale0)
        self._equilibrium = reached
        self._at_rest = False
        report.reached = t
        report.seconds = time.perf_counter() - tic
        return report
