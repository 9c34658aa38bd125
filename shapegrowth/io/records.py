"""The verification's typed records: what summary.json's ``verified`` (and its ``lifted``)
and verify.json's ``check`` hold.  optim/verification.py and optim/lift.py make them; the
summary, the report and the reproduction read them."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..physics.stability import Stability


@dataclass(frozen=True)
class Lifted:
    """summary.json's ``lifted``: the reduced growth on the 3D body, grown from rest."""

    hausdorff: float | None  # None where no equilibrium was found from rest
    relative: float | None  # hausdorff / the 3D target's size
    dofs: int  # state DOFs of the 3D model
    wall_s: float
    status: str  # "solved", or "failed: <reason>"
    config: str  # the 3D config's name
    # the largest distance of a 3D node from where the section puts it, over the 3D target's
    # size (None where either solve failed, or the section's state is not known)
    departure: float | None = None
    stability: Stability | None = None  # of the 3D body's state, its path from rest watched
    surface: float | None = None  # ``relative`` surface to surface (Verified.surface)
    # ``shapegrowth verify --continued``: the refinement of the check (Verified.refine) whose
    # 3D equilibrium, grown from rest, this state was continued from; None: from rest here
    continued_from: int | None = None

    def to_json(self) -> dict[str, object]:
        """summary.json's ``verified.lifted`` and lift.json's ``lifted``."""
        return {**dataclasses.asdict(self),
                "stability": self.stability.to_json() if self.stability else None}


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
# of its distance to the scenes' 1 % (docs/VERIFICATION.md, 'The verification, verified'): a
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
