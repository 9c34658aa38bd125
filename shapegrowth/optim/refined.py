"""The verified shape error: a growth judged on a refined model, grown from rest.

A run's own number is measured on the mesh it optimised on, at the equilibrium its warm
starts followed.  The body a user grows has neither: it starts at rest and is a continuum.
:func:`verify` carries the growth the body was given (the filtered fields lambda_hat,
theta_hat) onto the run's mesh refined ``refine`` times - nested, so a Lagrange field of
the growth's degree carries over exactly - solves the state there from rest by
continuation (its path watched for stability, and left for a stable branch where
``solver.branch`` is switch), and measures the exact Hausdorff distance to the target at the refined
model's sample points.  That is the number a run leads with (summary.json ``verified``).

Where the verified error exceeds the run's own by more than :data:`TOLERATED`, the likely
cause is named (:func:`likely_cause`): the *branch* when the growth solved from rest on the
run's own mesh already reaches another equilibrium than the optimiser's path, else the
*mesh* (the run's mesh does not resolve what its optimum leans on).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass

from .. import compat
from ..config import Config
from ..physics.model import ForwardModel
from ..physics.paths import Continued, equilibrium_from_rest, solve_watched
from ..physics.stability import Stability
from ..physics.state import SolveReport
from ..physics.transfer import interpolate_between_meshes
from .lift import Lifted
from .objective import measure_verified

log = logging.getLogger(__name__)

TOLERATED = 2.0  # verified / self beyond which a run warns


@dataclass(frozen=True)
class Verified:
    """summary.json's ``verified``: the growth on the mesh refined ``refine`` times, solved
    from rest there."""

    hausdorff: float | None  # None where no equilibrium was found from rest
    relative: float | None  # hausdorff / the refined target's size
    refine: int
    dofs: int  # state DOFs of the refined model
    wall_s: float
    branch_changed: bool  # from rest on the run's own mesh, another equilibrium than the run's
    status: str  # "solved", or "failed: <reason>"
    lifted: Lifted | None = None  # a reduced model's growth on its 3D body (verify.lift)
    stability: Stability | None = None  # of the verified state (physics/stability.py)
    # the boundaries' exact Hausdorff distance, surface to surface, over the target's size:
    # ``relative`` without its clouds' sampling (Objective.surface_hausdorff; None where not
    # measured: a file target compared as a volume, a failed solve, an older summary)
    surface: float | None = None
    # verify.best: verified: the run's iteration of verify.every's check whose growth this is
    # (None: the optimiser's best design, by its own number)
    iteration: int | None = None
    # ``shapegrowth verify --continued``: the refinement whose equilibrium, grown from rest,
    # this state was continued from (Newton at the full growth on this mesh); None: grown
    # from rest here
    continued_from: int | None = None

    @property
    def headline(self) -> float | None:
        """The number a run leads with: the lifted 3D error of a reduced model that was
        lifted, else the refined model's."""
        return self.lifted.relative if self.lifted is not None else self.relative

    @property
    def headline_surface(self) -> float | None:
        """The headline's model measured boundary to boundary (without the clouds'
        sampling), where it was."""
        return self.lifted.surface if self.lifted is not None else self.surface

    @property
    def headline_dofs(self) -> int:
        """The state DOFs of the model the headline was measured on."""
        return self.lifted.dofs if self.lifted is not None else self.dofs

    @property
    def headline_status(self) -> str:
        """"solved", or why the headline's model found no equilibrium from rest."""
        return self.lifted.status if self.lifted is not None else self.status

    @property
    def headline_stability(self) -> Stability | None:
        """The stability of the headline's state."""
        return self.lifted.stability if self.lifted is not None else self.stability

    @property
    def headline_continued_from(self) -> int | None:
        """The refinement the headline's state was continued from (None: from rest)."""
        return self.lifted.continued_from if self.lifted is not None else self.continued_from

    @property
    def check_wall_s(self) -> float:
        """The verification's wall time, the lift included."""
        return self.wall_s + (self.lifted.wall_s if self.lifted is not None else 0.0)

    def to_json(self) -> dict[str, object]:
        """summary.json's ``verified`` (``lifted`` only where a reduced model was lifted)."""
        out: dict[str, object] = dataclasses.asdict(self)
        if self.lifted is None:
            del out["lifted"]
        else:
            out["lifted"] = self.lifted.to_json()
        out["stability"] = self.stability.to_json() if self.stability else None
        return out


# A verified number holds when the mesh refined once more moves it by less than this share
# of its distance to the scenes' 1 % (docs/TRADEOFFS.md, 'The verification, verified'): a
# number the next refinement could carry across 1 % does not decide a scene.
SETTLED_SHARE = 1.0 / 3.0
ONE_PERCENT = 0.01


@dataclass(frozen=True)
class Reverified:
    """A finished run's verified number against the same growth verified on a finer mesh
    (``shapegrowth verify``): ``first`` is the run's headline (refined ``first_refine``
    times; lifted for a lifted section), ``second`` the new verification."""

    first: float | None
    first_refine: int
    second: Verified

    @property
    def second_headline(self) -> float | None:
        return self.second.headline

    @property
    def moved(self) -> float | None:
        """How far the finer mesh moved the number (a fraction of the target size)."""
        if self.first is None or self.second_headline is None:
            return None
        return abs(self.second_headline - self.first)

    @property
    def allowed(self) -> float | None:
        """A third of the way from the first number to 1 %."""
        return None if self.first is None else SETTLED_SHARE * abs(self.first - ONE_PERCENT)

    @property
    def settled(self) -> bool | None:
        """Whether the finer mesh moved the number by less than :attr:`allowed` (None where
        either verification failed)."""
        if self.moved is None or self.allowed is None:
            return None
        return self.moved < self.allowed

    def to_json(self) -> dict[str, object]:
        """verify.json's ``check``."""
        return {"first": self.first, "first_refine": self.first_refine,
                "second": self.second_headline, "second_refine": self.second.refine,
                "moved": self.moved, "allowed": self.allowed, "settled": self.settled}


def refined_config(cfg: Config, refine: int) -> Config:
    """``cfg`` on its mesh refined ``refine`` more times (nested in the run's mesh).  The
    model solved there is the run's own, its clouds included (they set where an
    equilibrium's det F is checked); :func:`verify` measures it with the verification's
    clouds (:func:`~shapegrowth.optim.objective.verification_clouds`)."""
    return dataclasses.replace(cfg, mesh=dataclasses.replace(
        cfg.mesh, refine=cfg.mesh.refine + refine))


def grown_from_rest(model: ForwardModel, cfg: Config) -> tuple[ForwardModel, SolveReport]:
    """The growth ``model`` is in equilibrium with, carried onto the discretisation of
    ``cfg`` (exactly where its mesh is nested in ``model``'s) and solved there from rest
    (collective): the verification's model, and the study's reference."""
    other = carried_to(model, cfg)
    return other, other.state.solve()


def carried_to(model: ForwardModel, cfg: Config) -> ForwardModel:
    """A model of ``cfg`` at rest, given the growth ``model`` is in equilibrium with."""
    other = ForwardModel.build(cfg, model.comm)
    for source, target in zip(model.state.applied.fields, other.growth.fields):
        interpolate_between_meshes(source, target)
    return other


def verify(model: ForwardModel, refine: int, branch_changed: bool = False,
           start: Continued | None = None) -> Verified:
    """The growth ``model`` is in equilibrium with, on its mesh refined ``refine`` times,
    solved from rest (collective).  ``start``: solved there at the full growth from the
    equilibrium grown from rest on a coarser mesh (:func:`verified_from_rest`;
    ``shapegrowth verify --continued``), that solve's wall time counted in the check's."""
    tic = time.perf_counter() - (0.0 if start is None else start.seconds)
    cfg = refined_config(model.cfg, refine)
    coarser = None if start is None else start.refine
    fine = carried_to(model, cfg)
    if start is not None:
        fine.state.carry(start.displacement)
    report, stability, _ = solve_watched(fine.state, cfg.solver.branch)
    dofs = compat.global_size(fine.state.V)
    if not report.converged:
        log.warning("verification: no equilibrium %s on the refined mesh: %s",
                    "from rest" if coarser is None else "near the coarser one", report.reason)
        return Verified(None, None, refine, dofs, time.perf_counter() - tic, branch_changed,
                        f"failed: {report.reason}", stability=stability,
                        continued_from=coarser)
    measured = measure_verified(cfg, fine.state)
    return Verified(measured.hausdorff, measured.relative, refine, dofs,
                    time.perf_counter() - tic, branch_changed, "solved", stability=stability,
                    surface=measured.surface, continued_from=coarser)


def verified_from_rest(model: ForwardModel, refine: int) -> tuple[Continued | None, str]:
    """The growth ``model`` is in equilibrium with, on its mesh refined ``refine`` times,
    grown from rest: the start of a check continued onto a finer mesh; None and the reason
    where no equilibrium was found (collective)."""
    start, report = equilibrium_from_rest(
        lambda: carried_to(model, refined_config(model.cfg, refine)).state, refine,
        model.cfg.solver.branch)
    if start is None:
        return None, f"from rest on the mesh refined {refine} time(s): {report.reason}"
    return start, "solved"


def branch_changed(from_rest: float | None, own: float, target_size: float) -> bool:
    """Whether the growth solved from rest on the run's own mesh (Hausdorff ``from_rest``)
    reaches another equilibrium than the optimiser's (``own``): more than 5 % apart, and
    more than 1e-3 of the target size.  A failed solve from rest counts as changed."""
    if from_rest is None:
        return True
    return abs(from_rest - own) > max(0.05 * own, 1e-3 * target_size)


def likely_cause(own_relative: float, verified: Verified) -> str | None:
    """None when the verified error is within :data:`TOLERATED` of the run's own, else the
    likely cause: "branch" or "mesh" (module doc)."""
    if verified.relative is None:
        return "branch" if verified.branch_changed else "mesh"
    if verified.relative <= TOLERATED * own_relative:
        return None
    return "branch" if verified.branch_changed else "mesh"
