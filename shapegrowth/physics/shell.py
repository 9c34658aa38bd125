"""A growth shell: the nonlinear Naghdi shell whose rest metric and rest curvature are set
by a growth that varies linearly through the wall.

The body is its mid-surface and its thickness t: a plane region, or a surface in space with
a frame on it (physics/shell_forms.py: the :class:`Reference`; the rest forms abar, bbar
the growth sets, :class:`RestForms`).  Kinematics and strains are FEniCSx-Shells' nonlinear
Naghdi shell: phi = X + u (three components), the director d(theta) the reference's normal
turned by two angles (in a chart the continuation moves with the wall), F = D phi (the
derivative along the frame's tangents), and

    a = F^T F,   b = -sym(F^T D d),   eps = (a - abar) / 2,   kappa = b - bbar,
    gamma = F^T d,

measured against the growth instead of the reference.  A growth whose metric and curvature
are those of a surface (Gauss and Codazzi hold) is grown stress-free: the closed forms of the
tests.  The energy per unit rest area sqrt(det abar) is that of a plane-stress linear
isotropic material on the grown metric,

    t/2 eps:A:eps + t^3/24 kappa:A:kappa + t/2 (5/6) mu gamma . abar^-1 gamma,
    A^abcd = lam_s abar^ab abar^cd + mu (abar^ac abar^bd + abar^ad abar^bc),

lam_s = 2 lam mu / (lam + 2 mu), mu and lam the material's small-strain moduli (the
shell's strains stay small where the growth is nearly attainable, so the linearisation of
any of the package's energies is its 2D reduction).  Membrane and shear locking are
treated by partial selective reduced integration (Arnold and Brezzi): a share t^2 / h^2 of
those two terms at the full quadrature degree 4, the rest of the membrane term at degree 1
and of the shear term at degree 2 (measured: :data:`MEMBRANE_DEGREE`), bending at 4.
P2 enriched by the cubic bubble for u, P2 for theta.

The growth is reached by continuation: the rest forms move from the reference's own
(abar = I, bbar = B0) to the growth's in steps, each solved by Newton's method (PETSc SNES,
an options prefix of its own), a failed step halved.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from .. import compat
from .linear import reason_of
from .options import SolverOptions
from .shell_forms import Reference, RestForms, ShellMaterial, turned

__all__ = ["GrowthShell", "Pin", "Reference", "RestForms", "ShellMaterial",
           "ShellSolveReport", "sub_function"]

log = logging.getLogger(__name__)

SHEAR_FACTOR = 5.0 / 6.0
FULL_DEGREE = 4  # bending, and the t^2/h^2 share of membrane and shear
# the rest of membrane and shear (PSRI).  The rolled strip (tests/test_shell.py), largest
# node error at 8/16/32 cells: membrane at degree 2 gave 3.5e-3/6.9e-4/7.8e-5 at t/L 1/100
# but 6.0e-3/3.9e-3/1.3e-3 at 1/600 (locked until h < ~10 t); at degree 1, 2.3e-3/5.9e-4/
# 1.4e-4 at both (rate 2 whatever the wall).  Shear at degree 1 found no equilibrium.
MEMBRANE_DEGREE = 1
SHEAR_DEGREE = 2


def sub_function(f: dolfinx.fem.Function, i: int) -> dolfinx.fem.Function:
    """Sub-field (or component) ``i`` of ``f`` as a Function of its own space."""
    space, dofs = f.function_space.sub(i).collapse()
    part = dolfinx.fem.Function(space)
    part.x.array[:] = f.x.array[dofs]
    return part


def _measure(mesh, degree: int) -> ufl.Measure:
    return ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": degree})


@dataclass(frozen=True)
class Pin:
    """A field held at zero at a mesh vertex: ``field`` 0 the displacement, 1 the director's
    angles; ``component`` one of its components, or None for all."""

    point: tuple[float, ...]  # (X1, X2) on a plane, (X1, X2, X3) on a surface in space
    field: int
    component: int | None = None


@dataclass
class ShellSolveReport:
    """How a solve went (from rest, or from the last equilibrium for a new design)."""

    converged: bool
    steps: int
    newton_iterations: int
    level: float  # the share of the growth reached
    failed_steps: int = 0  # continuation steps that failed and were halved


class GrowthShell:
    """The shell on ``mesh`` (a triangle mesh: of the plane, gdim 2, or of a surface in
    space, gdim 3, whose frame ``reference`` gives) of thickness ``thickness``, clamped
    (u = 0, theta = 0) on the boundary facets where ``clamped(x)`` holds (None: nowhere),
    and held at ``pins``, grown towards ``rest``.  ``design``: the Function the rest forms
    are made of, where gradients with respect to it are wanted (:meth:`gradient`).
    ``rebase``: None (the director's chart is the reference's, singular where a section has
    turned by half a turn), or the angle (rad) past which the continuation moves the chart
    onto its last equilibrium (:meth:`_rebase`; its Newton steps then backtrack)."""

    def __init__(self, mesh, thickness: float, material: ShellMaterial, rest: RestForms,
                 clamped: Callable[[np.ndarray], np.ndarray] | None, degree: int = 2,
                 design: dolfinx.fem.Function | None = None, pins: Sequence[Pin] = (),
                 reference: Reference | None = None, rebase: float | None = None):
        if reference is None:
            reference = Reference.plane(mesh)
        elif reference.mesh is not mesh:
            raise ValueError("the shell's reference is a frame on its own mesh")
        if rebase is not None and not 0.0 < rebase < np.pi / 2:
            raise ValueError(f"rebase {rebase}: an angle in (0, pi/2) rad, or None")
        self.rebase = rebase
        self.mesh, self.thickness, self.material = mesh, thickness, material
        self.reference, self.degree = reference, degree
        self.V = compat.shell_space(mesh, degree)
        self.q = dolfinx.fem.Function(self.V)
        self.level = compat.constant(mesh, 0.0)  # the share of the growth applied
        u, theta = ufl.split(self.q)
        eye = ufl.Identity(2)
        s = self.level
        B0 = reference.curvature
        abar = eye + s * (rest.metric - eye)
        bbar = B0 + s * (rest.curvature - B0)
        phi = reference.position() + u
        self.phi = phi  # the deformed mid-surface, for objectives
        F = reference.derivative(phi)  # 3 x 2
        # the director's chart: the reference's frame, turned (where the chart moves) by
        # the rotation I + ``_turn`` (a field of 3 x 3 matrices, zero until the continuation
        # re-bases the chart on an equilibrium, :meth:`_rebase`), then by theta
        t1, t2 = reference.tangents
        self._frame = (t1, t2, reference.normal)
        chart = self._frame
        self._turn: dolfinx.fem.Function | None = None
        if rebase is not None:
            self._turn = dolfinx.fem.Function(compat.vector_space(mesh, degree, 9))
            Q = ufl.Identity(3) + ufl.as_matrix([[self._turn[3 * r + c] for c in range(3)]
                                                 for r in range(3)])
            chart = tuple(Q * e for e in chart)
        self._turned = turned(theta, chart)
        d = self._turned[2]
        self.director = d  # the deformed wall's fibre, for objectives
        a = F.T * F
        Dd = reference.derivative(d)
        b = -0.5 * (F.T * Dd + Dd.T * F)
        eps, kappa, gamma = 0.5 * (a - abar), b - bbar, F.T * d
        inv = ufl.inv(abar)
        mu, lam_s, t = material.mu, material.plane_stress_lam, thickness
        i, j, k, m = ufl.indices(4)
        A = ufl.as_tensor(lam_s * inv[i, j] * inv[k, m]
                          + mu * (inv[i, k] * inv[j, m] + inv[i, m] * inv[j, k]), (i, j, k, m))

        def quadratic(e):
            return ufl.as_tensor(A[i, j, k, m] * e[k, m], (i, j))[i, j] * e[i, j]

        area = ufl.sqrt(ufl.det(abar))
        membrane = 0.5 * t * quadratic(eps) * area
        bending = t**3 / 24.0 * quadratic(kappa) * area
        shear = 0.5 * t * SHEAR_FACTOR * mu * ufl.dot(gamma, inv * gamma) * area
        share = t**2 / reference.cell_diameter() ** 2
        full = _measure(mesh, FULL_DEGREE)
        self.energy = (bending + share * (membrane + shear)) * full \
            + (1.0 - share) * membrane * _measure(mesh, MEMBRANE_DEGREE) \
            + (1.0 - share) * shear * _measure(mesh, SHEAR_DEGREE)
        test, trial = ufl.TestFunction(self.V), ufl.TrialFunction(self.V)
        residual = ufl.derivative(self.energy, self.q, test)
        self.residual_form = dolfinx.fem.form(residual)
        self.jacobian_form = dolfinx.fem.form(ufl.derivative(residual, self.q, trial))
        self.energy_form = dolfinx.fem.form(self.energy)
        self.design = design
        if design is not None:  # (dR/dm)^T lam: the residual along lam, differentiated in m
            self._lam = dolfinx.fem.Function(self.V)
            along = ufl.derivative(self.energy, self.q, self._lam)
            self._design_form = dolfinx.fem.form(
                ufl.derivative(along, design, ufl.TestFunction(design.function_space)))
        self.bcs = (self._clamp(clamped) if clamped is not None else []) + \
            [self._pin(pin) for pin in pins]
        if rebase is not None:  # the angles' entries of q, all and owned
            self._angle_dofs = np.asarray(self.V.sub(1).collapse()[1], dtype=np.int64)
            self._owned_angles = self._angle_dofs[
                self._angle_dofs < self.V.dofmap.index_map.size_local
                * self.V.dofmap.index_map_bs]
        self.A = compat.assemble_matrix(self.jacobian_form, self.bcs)
        self.A.assemble()
        self.b = compat.create_vector(self.residual_form)
        self._snes = self._newton()

    # ---- the equations ---------------------------------------------------------------------

    def _clamp(self, clamped) -> list:
        fdim = self.mesh.topology.dim - 1
        facets = dolfinx.mesh.locate_entities_boundary(self.mesh, fdim, clamped)
        bcs = []
        for field in range(2):
            sub = self.V.sub(field)
            space, _ = sub.collapse()
            zero = dolfinx.fem.Function(space)
            dofs = dolfinx.fem.locate_dofs_topological((sub, space), fdim, facets)
            bcs.append(dolfinx.fem.dirichletbc(zero, dofs, sub))
        return bcs

    def _pin(self, pin: Pin):
        sub = self.V.sub(pin.field)
        if pin.component is not None:
            sub = sub.sub(pin.component)
        space, _ = sub.collapse()
        point = np.asarray(pin.point, dtype=float)
        if len(point) != self.mesh.geometry.dim:
            raise ValueError(f"shell: a pinned point has {self.mesh.geometry.dim} "
                             f"coordinates here, not {len(point)}")
        vertices = dolfinx.mesh.locate_entities(
            self.mesh, 0, lambda x: np.all(np.isclose(x[:len(point)].T, point), axis=1))
        if self.mesh.comm.allreduce(len(vertices), op=MPI.SUM) == 0:
            raise ValueError(f"shell: no mesh vertex at the pinned point {pin.point}")
        # dolfinx 0.9 and later find a vertex's dofs through its cells, made on demand
        self.mesh.topology.create_connectivity(0, self.mesh.topology.dim)
        dofs = dolfinx.fem.locate_dofs_topological((sub, space), 0, vertices)
        return dolfinx.fem.dirichletbc(dolfinx.fem.Function(space), dofs, sub)

    def _at(self, x: PETSc.Vec) -> None:
        """The unknowns q <- x (ghosts updated)."""
        q = compat.petsc_vec(self.q)
        if x.handle != q.handle:
            x.copy(q)
        q.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    def _residual(self, _snes, x: PETSc.Vec, b: PETSc.Vec) -> None:
        self._at(x)
        with b.localForm() as local:
            local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, self.residual_form)
        compat.apply_lifting(b, [self.jacobian_form], [self.bcs], [x], alpha=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        compat.set_bc(b, self.bcs, x, alpha=-1.0)

    def _tangent(self, _snes, x: PETSc.Vec, A: PETSc.Mat, _P: PETSc.Mat) -> None:
        self._at(x)  # a line search's last residual may have been at a rejected point
        A.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(A, self.jacobian_form, bcs=self.bcs)
        A.assemble()

    def _newton(self) -> PETSc.SNES:
        snes = PETSc.SNES().create(self.mesh.comm)
        self.options = SolverOptions("state_", {
            "snes_type": "newtonls", "snes_max_it": 25,
            # a moving chart's steps turn the wall by large angles: backtracking
            "snes_linesearch_type": "basic" if self.rebase is None else "bt",
            "snes_rtol": 1e-10, "snes_atol": 1e-12 * self._force_scale(), "snes_stol": 0.0,
            "ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"})
        snes.setOptionsPrefix(self.options.prefix)
        snes.setFunction(self._residual, self.b)
        snes.setJacobian(self._tangent, self.A)
        with self.options.pushed():
            snes.setFromOptions()
        return snes

    def _force_scale(self) -> float:
        """mu t times the plane region's area: the size of a residual of unit strain."""
        one = dolfinx.fem.form(compat.constant(self.mesh, 1.0) * ufl.dx(domain=self.mesh))
        area = self.mesh.comm.allreduce(dolfinx.fem.assemble_scalar(one))
        return self.material.mu * self.thickness * float(area)

    # ---- the solve -------------------------------------------------------------------------

    def solve(self, initial_step: float = 0.25, min_step: float = 1.0 / 256) -> ShellSolveReport:
        """Grow from where the last solve ended to the whole growth, by continuation; where
        the whole growth was reached before (a new design), Newton from the last equilibrium
        first, and from rest where that fails.  Where the flat state can buckle either way
        (a metric of K != 0), the step decides the branch: a disk grown into a spherical cap
        in steps of 1/4 ended on the mirror cap at 16 cells across, in steps of 1/20 on the
        cap (tests/test_shell.py)."""
        if float(self.level.value) >= 1.0:
            x = compat.petsc_vec(self.q).copy()
            with self.options.pushed():
                self._snes.solve(None, x)
            iterations = self._snes.getIterationNumber()
            if reason_of(self._snes) > 0:
                self._at(x)
                return ShellSolveReport(True, 1, iterations, 1.0)
            self.q.x.array[:] = 0.0
            self._reset_chart()
            self.level.value = 0.0
        return self._continue(initial_step, min_step)

    def _reset_chart(self) -> None:
        if self._turn is not None:
            self._turn.x.array[:] = 0.0

    def _rebase(self, x: PETSc.Vec) -> np.ndarray | None:
        """Where the angles of the equilibrium q (= x) exceed :attr:`rebase` somewhere, the
        chart is moved onto it: the frame turned by theta at the nodes becomes the frame
        and theta is set to 0 (the same director at the nodes).  The chart holds the
        rotation that turns the reference's own frame onto it, interpolated between the
        nodes: a section turned as a whole turns its frame by one rotation, as smooth as
        the turn, while the reference's curvature stays exact.  The chart's one
        singularity, th1 = +-pi/2, is then a quarter turn from the wall's present place,
        not from its reference.  Returns the angles taken off this rank's owned entries
        of x (None where the chart stays) (collective)."""
        if self.rebase is None or self._turn is None:
            return None
        taken = x.array[self._owned_angles].copy()
        largest = float(np.abs(taken).max(initial=0.0))
        if self.mesh.comm.allreduce(largest, op=MPI.MAX) <= self.rebase:
            return None
        rotation = sum((ufl.outer(a, e) for a, e in zip(self._turned, self._frame)),
                       -ufl.Identity(3))  # the new turn: sum_i a_i (x) e_i - I
        moved = dolfinx.fem.Function(self._turn.function_space)
        compat.interpolate_expression(
            moved, ufl.as_vector([rotation[r, c] for r in range(3) for c in range(3)]))
        self._turn.x.array[:] = moved.x.array
        self.q.x.array[self._angle_dofs] = 0.0
        self.q.x.scatter_forward()
        compat.petsc_vec(self.q).copy(x)
        return taken

    def _continue(self, initial_step: float, min_step: float) -> ShellSolveReport:
        q = compat.petsc_vec(self.q)
        # SNES's own iterate: the callbacks copy the point they are given into q, so q
        # must not be the iterate a line search steps from
        x = q.copy()
        level, step, steps, iterations = float(self.level.value), initial_step, 0, 0
        failed = 0
        before: tuple[float, PETSc.Vec] | None = None  # the equilibrium one step back
        while level < 1.0:
            trial = min(1.0, level + step)
            saved = x.copy()
            if before is not None:  # the secant predictor: the path's last step, extended
                x.axpy((trial - level) / (level - before[0]), x - before[1])
            self.level.value = trial
            with self.options.pushed():
                self._snes.solve(None, x)
            reason = reason_of(self._snes)
            iterations += self._snes.getIterationNumber()
            if reason > 0:
                self._at(x)
                taken = self._rebase(x)
                if taken is not None:  # the last step's angles in the new chart (to first
                    saved.array[self._owned_angles] -= taken  # order): the predictor holds
                before = (level, saved)
                level, steps = trial, steps + 1
                step = min(2.0 * step, initial_step)
                continue
            log.debug("shell: step to %.4g failed (SNES reason %d after %d iterations)",
                      trial, reason, self._snes.getIterationNumber())
            saved.copy(x)
            self._at(x)
            self.level.value = level
            step *= 0.5
            failed += 1
            if step < min_step:
                log.warning("shell: no equilibrium past %.4g of the growth", level)
                return ShellSolveReport(False, steps, iterations, level, failed)
        return ShellSolveReport(True, steps, iterations, level, failed)

    # ---- results ---------------------------------------------------------------------------

    def mid_surface(self) -> tuple[np.ndarray, np.ndarray]:
        """The owned Lagrange nodes' reference points (n, gdim) and their deformed places
        phi (n, 3)."""
        u = self.nodal_displacement()
        owned = u.function_space.dofmap.index_map.size_local
        gdim = self.mesh.geometry.dim
        X = u.function_space.tabulate_dof_coordinates()[:owned, :gdim]
        phi = u.x.array.reshape(-1, 3)[:owned].copy()
        phi[:, :gdim] += X
        return X, phi

    def nodal_displacement(self) -> dolfinx.fem.Function:
        """u at the Lagrange nodes of the shell's degree, a Function of that vector space
        (the displacement's bubbles vanish at the nodes)."""
        u = dolfinx.fem.Function(compat.vector_space(self.mesh, self.degree, 3))
        u.interpolate(self.displacement())
        return u

    def displacement(self) -> dolfinx.fem.Function:
        """u as a Function of its own space."""
        return sub_function(self.q, 0)

    def director_field(self) -> dolfinx.fem.Function:
        """The director d at the Lagrange nodes of the shell's degree (a vector Function)."""
        d = dolfinx.fem.Function(compat.vector_space(self.mesh, self.degree, 3))
        compat.interpolate_expression(d, self.director)
        return d

    def angles(self) -> dolfinx.fem.Function:
        """The director's angles theta as a Function of their own space."""
        return sub_function(self.q, 1)

    def gradient(self, objective: ufl.Form) -> tuple[float, dolfinx.fem.Function]:
        """J and dJ/dm at the current equilibrium for a functional ``objective`` J(q, m) (an
        integral over the plane: of :attr:`phi`, :attr:`q`, the design): the adjoint
        K lam = dJ/dq (the tangent K is symmetric; lam = 0 where q is clamped), then
        dJ/dm = dJ/dm|_q - (dR/dm)^T lam."""
        if self.design is None:
            raise ValueError("the shell was built without a design: no gradient")
        comm = self.mesh.comm
        value = comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(objective)))
        rhs = dolfinx.fem.petsc.assemble_vector(dolfinx.fem.form(
            ufl.derivative(objective, self.q, ufl.TestFunction(self.V))))
        rhs.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        compat.set_bc(rhs, self.bcs, None, alpha=0.0)
        self._tangent(None, compat.petsc_vec(self.q), self.A, self.A)
        ksp = PETSc.KSP().create(comm)
        ksp.setOperators(self.A)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType("mumps")
        lam = compat.petsc_vec(self._lam)
        ksp.solve(rhs, lam)
        lam.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        ksp.destroy()
        space = self.design.function_space
        mhat = ufl.TestFunction(space)
        gradient = dolfinx.fem.Function(space)
        g = compat.petsc_vec(gradient)
        explicit = ufl.derivative(objective, self.design, mhat)
        if explicit.empty():
            g.set(0.0)
        else:
            dolfinx.fem.petsc.assemble_vector(g, dolfinx.fem.form(explicit))
        g.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        adjoint = dolfinx.fem.petsc.assemble_vector(self._design_form)
        # each part's ghost contributions to their owners before the sum: axpy adds only
        # the owned entries
        adjoint.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        g.axpy(-1.0, adjoint)
        g.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        adjoint.destroy()
        rhs.destroy()
        return float(value), gradient

    def negative_eigenvalues(self) -> int:
        """The tangent's negative eigenvalues at the current state, the inertia of MUMPS's
        LDL^T of it (the clamped rows are the identity's): 0 where the equilibrium is stable
        (collective)."""
        self._tangent(None, compat.petsc_vec(self.q), self.A, self.A)
        self.A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        options = SolverOptions("stability_", {
            "ksp_type": "preonly", "pc_type": "cholesky", "pc_factor_mat_solver_type": "mumps",
            "mat_mumps_icntl_13": 1,  # no ScaLAPACK root: its pivots are not counted
            "mat_mumps_icntl_24": 0})
        ksp = PETSc.KSP().create(self.mesh.comm)
        ksp.setOptionsPrefix(options.prefix)
        ksp.setOperators(self.A)
        with options.pushed():
            ksp.setFromOptions()
            ksp.setUp()
        negative = int(ksp.getPC().getFactorMatrix().getMumpsInfog(12))
        ksp.destroy()
        return negative

    def energy_value(self) -> float:
        return float(self.mesh.comm.allreduce(dolfinx.fem.assemble_scalar(self.energy_form)))
