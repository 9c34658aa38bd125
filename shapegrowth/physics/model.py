"""The forward model put together: mesh, growth fields and state for one config, and
the quantities a solved body reports (volumes, stress, residual strain)."""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass

import dolfinx.fem
import numpy as np
import ufl
from mpi4py import MPI

from .. import blas, compat
from ..config import Config, resolved
from .geometry import Domain, load_domain
from .growth import Growth
from .state import StateProblem

log = logging.getLogger("shapegrowth")


@dataclass
class ForwardModel:
    cfg: Config
    domain: Domain
    growth: Growth
    state: StateProblem

    @classmethod
    def build(cls, cfg: Config, comm: MPI.Comm = MPI.COMM_WORLD) -> ForwardModel:
        """Mesh, growth fields and state for ``cfg``; warns once per process where the BLAS
        runs a fallback kernel set (a notebook started without the environment the command
        line sets: :mod:`shapegrowth.blas`)."""
        _warn_of_slow_blas()
        domain = load_domain(cfg, comm)
        growth = Growth.from_config(domain.mesh, cfg)
        state = StateProblem(domain, cfg, growth)
        return cls(cfg, domain, growth, state)

    @property
    def comm(self) -> MPI.Comm:
        return self.domain.mesh.comm

    @property
    def displacement(self) -> dolfinx.fem.Function:
        """The state's displacement u (Phi = X + u)."""
        return self.state.u

    @property
    def applied(self) -> Growth:
        """The growth the displacement is in equilibrium with."""
        return self.state.applied

    def state_dofs(self) -> int:
        """The state's degrees of freedom, all ranks."""
        return compat.global_size(self.state.V)

    def integrate(self, integrand: ufl.core.expr.Expr) -> float:
        """The integral over the reference body (2 pi R weighted for a body of revolution)."""
        form = dolfinx.fem.form(integrand * self.state.weight * self.state.dx)
        return self.comm.allreduce(dolfinx.fem.assemble_scalar(form), MPI.SUM)

    def volumes(self) -> tuple[float, float]:
        """Reference and deformed volume (area in 2D, per unit width in a plane section)."""
        one = dolfinx.fem.Constant(self.domain.mesh, 1.0)
        return self.integrate(one), self.integrate(self.state.volume_ratio())

    def stress_norm(self) -> float:
        """L2 norm of the first Piola-Kirchhoff stress over the reference body."""
        P = self.state.first_piola()
        return float(np.sqrt(max(self.integrate(ufl.inner(P, P)), 0.0)))

    def residual_strain(self) -> ufl.core.expr.Expr:
        """A^T A - I with A = F G^-1, the elastic strain the growth leaves: zero where the body
        grew stress-free (compatible growth), nonzero where growth is incompatible."""
        kin, state = self.state.kinematics, self.state
        Cg3 = kin.growth(state.applied.tensor())
        F3 = kin.deformation(state.deformation_gradient(), state.u, Cg3)
        A = F3 * kin.growth(state.applied.inverse_root())
        return A.T * A - ufl.Identity(A.ufl_shape[0])

    def residual_strain_norm(self) -> float:
        """RMS of |A^T A - I| over the reference body: sqrt(int |E|^2 / |body|)."""
        E = self.residual_strain()
        one = dolfinx.fem.Constant(self.domain.mesh, 1.0)
        return float(np.sqrt(max(self.integrate(ufl.inner(E, E)), 0.0) / self.integrate(one)))

    def residual_strain_field(self) -> dolfinx.fem.Function:
        """|A^T A - I| as a P1 field for fields.xdmf."""
        f = dolfinx.fem.Function(compat.scalar_space(self.domain.mesh, 1), name="residual_strain")
        E = self.residual_strain()
        compat.interpolate_expression(f, ufl.sqrt(ufl.inner(E, E)))
        return f

    def design_dofs(self) -> int:
        g = self.cfg.growth
        angles = len(self.growth.angles) if g.frame == "free" else 0
        n_fields = len(resolved(g.eigenvalues.design)) + angles
        return n_fields * compat.global_size(self.growth.space)


def build_model(cfg: Config, comm: MPI.Comm = MPI.COMM_WORLD) -> ForwardModel:
    """Mesh, growth fields (at the config's initial growth) and state for ``cfg``."""
    return ForwardModel.build(cfg, comm)


@functools.cache
def _warn_of_slow_blas() -> None:
    message = blas.kernel_warning()
    if message is not None:
        log.warning("%s", message)
