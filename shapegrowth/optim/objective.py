"""The objective J = S(deformed body, target) + complexity, with its partial
derivatives: with respect to u (for the adjoint) and, for the complexity terms,
explicitly with respect to the growth fields.  S is the debiased rho_H (divergence.py)
or, with ``objective.hausdorff.form: paper``, rho_H of (2.9) itself."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from ..config import Config
from ..physics.state import StateProblem
from ..shape.clouds import QuadratureCloud, assemble
from ..shape.divergence import ShapeDivergence
from ..shape.facet_clouds import FacetCloud, boundary_facets
from ..shape.hausdorff import PointCloud, SmoothHausdorff, exact_hausdorff
from ..shape.rigid_fit import RigidFit
from ..shape.surface_distance import Simplices, surface_hausdorff
from ..shape.targets import mapped_points, rank_share, surface_target, target_cloud
from .complexity import complexity_density

# A verification measures with clouds of at least this quadrature degree, whatever the run
# optimised with (objective.hausdorff.quadrature_degree 1 or 2 is cheaper to optimise with:
# docs/PERFORMANCE.md), so that verified numbers compare from run to run.  Degree 6, not 2:
# measured on every scene's optimum (docs/VERIFICATION.md, 'The verified number's
# sampling'), degree 6 reads within 0.09 points of surface to surface on every run, degree 2
# up to 0.40 points above it where the material slid along the target (scene 2's ring:
# 1.03 % at degree 2, 0.66 % at 6, 0.64 % surface to surface); the clouds cost seconds,
# the solve from rest minutes.  They measure only: the state is solved from the run's own
# config, whose clouds set where det F is checked (checked at degree 6 points instead, three
# of the 3D cube's four verifications from rest stopped at 0.82-0.83 of the growth, det F
# <= 0 at one point: what a state must satisfy changed with how it was measured).
VERIFY_CLOUD_DEGREE = 6


def verification_clouds(cfg: Config) -> Config:
    """``cfg`` with clouds of quadrature degree VERIFY_CLOUD_DEGREE at least: the config a
    verified number is measured with."""
    h = cfg.objective.hausdorff
    if h.quadrature_degree >= VERIFY_CLOUD_DEGREE:
        return cfg
    return dataclasses.replace(cfg, objective=dataclasses.replace(
        cfg.objective, hausdorff=dataclasses.replace(h, quadrature_degree=VERIFY_CLOUD_DEGREE)))


@dataclass(frozen=True)
class Measured:
    """A verified state's numbers: its exact Hausdorff distance to the target, the target's
    size, the distance over that size, and surface to surface over it (None without one)."""

    hausdorff: float
    target_size: float
    relative: float
    surface: float | None


def measure_verified(cfg: Config, state: StateProblem) -> Measured:
    """``state`` (in equilibrium, solved from ``cfg``) measured as a verified number is:
    with the verification's clouds (:func:`verification_clouds`), the one place a
    verification and a lift both measure through (collective)."""
    objective = Objective(verification_clouds(cfg), state)
    hausdorff = objective.exact_hausdorff()
    size = objective.target_size
    return Measured(hausdorff, size, hausdorff / size if size > 0 else math.inf,
                    objective.surface_relative())


LATTICE = 4  # a face's facets in 4^2 flat triangles (2 x 4^2 on a hexahedron's quadrilaterals,
# 4 segments in 2D) for its distance: a P2 facet's sag over a quarter of it, 1/16 of its own


@dataclass(frozen=True)
class _Surface:
    """A face measured surface to surface: its cloud, the target's pieces (whole on every
    rank) and the target's points on this rank (the probes)."""

    cloud: FacetCloud
    pieces: Simplices
    probes: np.ndarray


@dataclass
class ObjectiveValue:
    total: float  # shape + complexity: what the optimiser minimises
    rho_H: float  # rho_H(body, target) of (2.9)
    complexity: float
    d_target_to_body: float
    d_body_to_target: float
    hausdorff: float  # exact Hausdorff distance: of the clouds (a by-product of rho_H), or of
    # the surfaces where a face is compared
    shape: float  # the shape term: the debiased divergence S, or rho_H (form: paper)
    alpha: float  # the alpha it was evaluated at
    stability: float = 0.0  # the stability penalty in total (optimizer.stability)
    lowest_eigenvalue: float | None = None  # the tangent's, where the penalty computed it
    grey: float = 0.0  # growth.grey_penalty's term in total (w D)


class Objective:
    def __init__(self, cfg: Config, state: StateProblem):
        h = cfg.objective.hausdorff
        mesh = state.domain.mesh
        self.comm = mesh.comm
        self.state = state
        faces = cfg.objective.faces(cfg.geometry.kind)
        # the compared part: the body's volume, or (objective.compare) a face or the whole
        # boundary as a cloud of its facets
        self.cloud: QuadratureCloud | FacetCloud
        if faces is None:
            self.cloud = QuadratureCloud(mesh, h.quadrature_degree, state.weight)
            ratio = state.volume_ratio() if cfg.section.reduced else None  # None: det F
            self._deformed = self.cloud.deformed_factory(state.u, ratio)
            self._pullback, self._fill = self.cloud.pullback_form(state.u, ratio)
        else:
            self.cloud = FacetCloud(state.V, _facets(state, faces), h.quadrature_degree,
                                    axisymmetric=cfg.section.axisymmetric)
        # objective.placement: fitted: a free body's compared part in its best-fit placement
        self.fit: RigidFit | None = None
        target_fit = None
        if cfg.objective.placement == "fitted":
            reference = self.cloud.reference()
            self.fit = RigidFit(reference.points, reference.weights, self.comm,
                                axial=cfg.section.axisymmetric)
            if cfg.target is not None and cfg.target.map is not None:
                # a map's image has the body's points: its shape is placed the same way (its
                # own fit: the body's is recomputed at every state)
                target_fit = RigidFit(reference.points, reference.weights, self.comm,
                                      axial=cfg.section.axisymmetric)
        # a face's exact Hausdorff distance is measured surface to surface
        # (surface_distance.py): the face against the target's pieces and its points
        self._face: _Surface | None = None
        if isinstance(self.cloud, FacetCloud) and cfg.target is not None \
                and cfg.target.map is None:
            self.target, nodes, cells = surface_target(cfg, self.cloud, self.comm)
            self._face = _Surface(self.cloud, Simplices(nodes[cells]),
                                  nodes[rank_share(len(nodes), self.comm)])  # a file's vertices
        else:
            self.target = target_cloud(cfg, self.cloud, self.comm)
        if target_fit is not None:
            self.target = PointCloud(target_fit(self.target.points), self.target.weights)
        self._target_fit = target_fit
        if isinstance(self.cloud, FacetCloud) and self._face is None:
            self._face = self._mapped_surface(cfg, self.cloud)
        # a volume cloud's boundary, measured surface to surface (surface_hausdorff), built
        # on first use: a map target's only
        self._boundary: _Surface | None = None
        self._boundary_of = cfg if (faces is None and cfg.target is not None
                                    and cfg.target.map is not None) else None
        # of the sample points, as rho_H sees it; a section of a body of revolution is
        # measured against the revolved body's size (its diameter), as its 3D body and its
        # lift are: two surfaces of revolution about one axis are as far apart (Hausdorff)
        # as their sections (a nearest point lies in the same meridian), so the section's
        # relative error then reads as the 3D body's would
        self.target_size = self.target.extent(self.comm, revolved=cfg.section.axisymmetric)
        self.divergence = ShapeDivergence(
            SmoothHausdorff(alpha=h.alphas[0], beta=h.beta, gamma=h.gamma, phi=h.phi,
                            cutoff=h.cutoff, taper=h.taper, precision=h.precision), h.form)
        density = complexity_density(cfg.objective.complexity, state.applied)
        self._complexity = None
        if density is not None:
            dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": 4})
            mu = ufl.TestFunction(state.applied.space)
            self._complexity = dolfinx.fem.form(density * dx)
            self._complexity_derivatives = [
                dolfinx.fem.form(ufl.derivative(density * dx, f, mu)) for f in state.applied.fields]

    @property
    def alpha(self) -> float:
        return self.divergence.rho.alpha

    def set_alpha(self, alpha: float) -> None:
        """Sharpen (or soften) the shape term: one stage of an alpha schedule."""
        if alpha != self.alpha:
            self.divergence = self.divergence.with_alpha(alpha)

    def stopping_scale(self) -> float:
        """The size of an objective change that counts as progress near the optimum, for
        Newton's tolerance along the run (solver.rtol_far): the debiased S tends to 0 at the
        target, so a change relative to S itself would never be small; rho_H(T, T), the value
        rho_H of (2.9) takes there, is the scale the paper form's relative change sees.  0 for
        the paper form.  (The optimiser's stopping test is relative to J itself: its floor is
        the mesh's: docs/VERIFICATION.md, 'Where the stopping test stops'.)"""
        if not self.divergence.debiased:
            return 0.0
        return self.divergence.target_self(self.target, self.comm)

    @property
    def face(self) -> FacetCloud | None:
        """The compared face's cloud (None where the volume is compared)."""
        return self.cloud if isinstance(self.cloud, FacetCloud) else None

    def deformed(self) -> PointCloud:
        """The compared part of the deformed body (placed by objective.placement)."""
        cloud = (self.cloud.deformed(self.state.u) if isinstance(self.cloud, FacetCloud)
                 else self._deformed())
        if self.fit is None:
            return cloud
        return PointCloud(self.fit(cloud.points), cloud.weights)

    def evaluate(self, gradient: bool) -> tuple[ObjectiveValue, PETSc.Vec | None]:
        """J at the current state; with ``gradient``, also dJ/du as a vector."""
        result = self.divergence(self.deformed(), self.target, self.comm, gradient=gradient)
        pair = result.pair
        complexity = 0.0
        if self._complexity is not None:
            complexity = self.comm.allreduce(
                dolfinx.fem.assemble_scalar(self._complexity), MPI.SUM)
        hausdorff = (pair.hausdorff if self._face is None
                     else self._surface_hausdorff(self._face))
        value = ObjectiveValue(result.value + complexity, pair.value, complexity,
                               pair.d_target_to_body, pair.d_body_to_target,
                               hausdorff, result.value, self.alpha)
        if not gradient:
            return value, None
        assert result.grad_points is not None and result.grad_weights is not None
        grad_points = result.grad_points
        if self.fit is not None:  # through the placement (rigid_fit.py)
            grad_points = self.fit.pullback(grad_points)
        if isinstance(self.cloud, FacetCloud):
            return value, self.cloud.pullback(self.state.u, grad_points, result.grad_weights)
        self._fill(grad_points, result.grad_weights)
        return value, assemble(self._pullback)

    def explicit_growth_derivatives(self) -> list[PETSc.Vec] | None:
        """dJ/d(growth field) at fixed u: the complexity terms only (None without them)."""
        if self._complexity is None:
            return None
        return [assemble(form) for form in self._complexity_derivatives]

    def placements(self) -> tuple[Callable[[np.ndarray], np.ndarray] | None,
                                  Callable[[np.ndarray], np.ndarray] | None]:
        """How points of the body (mesh coordinates, at the current state) and of a map's
        image are placed to be compared (objective.placement: fitted), for figures; None
        where they stand as they are (collective)."""
        if self.fit is None:
            return None, None
        self.deformed()  # the placement of the current state
        target = None if self._target_fit is None else self._target_fit.place
        return self.fit.place, target

    def exact_hausdorff(self) -> float:
        """The exact Hausdorff distance: of the clouds, or of a face's surfaces."""
        deformed = self.deformed()  # (and the placement of the current state)
        if self._face is not None:
            return self._surface_hausdorff(self._face)
        return exact_hausdorff(deformed, self.target, self.comm)

    def surface_hausdorff(self) -> float | None:
        """The exact Hausdorff distance between the deformed body's boundary and the
        target's, surface to surface, at the current state: a compared face's, or for a body
        compared as a volume with a map target its whole boundary against the map's image of
        it (None for a file target compared as a volume) (collective).

        A volume's own exact distance is between its clouds' points, and two clouds of one
        body slid along itself are apart by up to their spacing (the ring's verification
        cloud, turned about its axis by 0.003 of a turn or more: 0.94-1.03 % of its size,
        where the two bodies are one set): that part is sampling, not shape.  Between the
        boundaries there is no sampling, and the boundary is measured where it is (a
        volume's quadrature points lie inside its cells), so this distance can read higher
        than the clouds' as well as lower (docs/VERIFICATION.md, "The verified number's
        sampling")."""
        if self._face is None and self._boundary is None:
            if self._boundary_of is None:
                return None
            h = self._boundary_of.objective.hausdorff
            cloud = FacetCloud(self.state.V, boundary_facets(self.state.domain.mesh),
                               h.quadrature_degree,
                               axisymmetric=self._boundary_of.section.axisymmetric)
            self._boundary = self._mapped_surface(self._boundary_of, cloud)
        if self.fit is not None:
            self.deformed()  # the placement of the current state
        surface = self._face if self._face is not None else self._boundary
        assert surface is not None
        return self._surface_hausdorff(surface)

    def surface_relative(self) -> float | None:
        """:meth:`surface_hausdorff` over the target's size (collective)."""
        surface = self.surface_hausdorff()
        return None if surface is None or self.target_size <= 0 else surface / self.target_size

    def _mapped_surface(self, cfg: Config, cloud: FacetCloud) -> _Surface:
        """``cloud`` against target.map's image of its flat pieces (whole on every rank,
        placed as the target is) and of this rank's points (the probes)."""
        X, _, pieces = cloud.lattice(None, LATTICE)
        image, _ = mapped_points(cfg, X)
        if self._target_fit is not None:
            image = self._target_fit.place(image)
        return _Surface(cloud, Simplices(np.concatenate(self.comm.allgather(image[pieces]))),
                        image)

    def _surface_hausdorff(self, surface: _Surface) -> float:
        """The deformed face (its facets in flat pieces) against the target's pieces, each
        side's points measured to the other's pieces, at the placement last computed."""
        _, moved, pieces = surface.cloud.lattice(self.state.u, LATTICE)
        if self.fit is not None:
            moved = self.fit.place(moved)
        body = Simplices(np.concatenate(self.comm.allgather(moved[pieces])))
        return surface_hausdorff(moved, body, surface.probes, surface.pieces, self.comm)

    def relative_error(self) -> float:
        return self.exact_hausdorff() / self.target_size if self.target_size > 0 else np.inf


def _facets(state: StateProblem, faces: tuple[str, ...]) -> np.ndarray:
    """The local facets of the named boundaries (all of the boundary for ())."""
    domain = state.domain
    return domain.facets(faces) if faces else boundary_facets(domain.mesh)
