"""summary.json as a type: :class:`RunSummary`, written by ``solve`` and ``run``, read by
``study`` and the scripts.  Its JSON keys are the users' contract (their scripts read
them); ``to_json`` writes them flat (the forward solve's and the optimisation's own
measures beside the common ones) and ``from_json`` reads them back."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from ..io.records import Lifted, Verified
from ..physics.stability import Stability
from ..status import Outcome


@dataclass(frozen=True)
class Dofs:
    state: int
    design: int


@dataclass(frozen=True)
class Probe:
    """A reference point X and its deformed position Phi(X) (``--probe``)."""

    reference: tuple[float, ...]
    deformed: tuple[float, ...]


@dataclass(frozen=True)
class SolveMeasures:
    """What ``shapegrowth solve`` measures beyond the common keys."""

    volume_reference: float
    volume_deformed: float
    stress_l2: float
    residual_strain: float
    probes: tuple[Probe, ...] = ()


@dataclass(frozen=True)
class OptimizationMeasures:
    """What ``shapegrowth run`` measures beyond the common keys."""

    evaluations: int
    residual_strain: float | None  # None: not measured (a shell run's, on its 3D body's terms)
    # the best growth applied to the body at rest (None where that solve failed)
    rho_H_from_rest: float | None
    hausdorff_from_rest: float | None
    resumed: bool


@dataclass(frozen=True)
class LinearSolverUse:
    """``solver.linear`` as used: the preset (``auto`` resolved on the run's last model), why,
    the solves that fell back to the exact factorisation (physics/linear.py), and an
    iterative preset's Newton steps with their Krylov iterations."""

    preset: str
    fallbacks: int
    state_fallbacks: int
    adjoint_fallbacks: int
    reasons: tuple[str, ...] = ()
    reason: str = ""
    krylov_solves: int = 0
    krylov_iterations: int = 0


@dataclass(frozen=True)
class RunSummary:
    name: str
    status: Outcome
    iterations: int
    objective_initial: float | None
    objective_final: float | None
    rho_H_initial: float | None
    rho_H_final: float | None
    hausdorff_initial: float | None
    hausdorff_final: float | None
    target_size: float | None
    wall_time_s: float
    time_split: dict[str, float]
    newton_iterations_total: int
    continuation_steps: int
    failed_steps: int
    growth_reached: float
    dofs: Dofs
    mpi_size: int
    version: str
    dolfinx_version: str
    mesh: str
    config: dict[str, Any] = field(repr=False)
    solve: SolveMeasures | None = None
    optimization: OptimizationMeasures | None = None
    verified: Verified | None = None  # a run's verified shape error (verify.enabled)
    peak_memory_mb: float | None = None  # resident memory high-water mark, summed over ranks
    linear_solver: LinearSolverUse | None = None
    stability: Stability | None = None  # of the final state (solve)
    # growth.levels: the run folder's fabrication.json (io/fabrication.py), else None
    fabrication: str | None = None

    @property
    def relative_error(self) -> float | None:
        """The final exact Hausdorff distance over the target size (self-reported: on the
        run's own mesh, along its own path)."""
        if self.hausdorff_final is None or not self.target_size:
            return None
        return self.hausdorff_final / self.target_size

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name in ("solve", "optimization"):
                if value is not None:
                    out.update(_plain(value))
            elif f.name == "verified":
                if value is not None:
                    out["verified"] = value.to_json()
            elif f.name == "status":
                out["status"] = str(value)
            elif f.name == "stability":
                if value is not None:
                    out["stability"] = value.to_json()
            else:
                out[f.name] = _plain(value)
        return out

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> RunSummary:
        names = {f.name for f in dataclasses.fields(cls)} - {"solve", "optimization", "verified"}
        # keys older summaries lack
        names -= {"peak_memory_mb", "linear_solver", "stability", "fabrication"} - set(data)
        common: dict[str, Any] = {k: data.get(k) for k in names}
        if data.get("stability"):
            common["stability"] = _stability(data["stability"])
        if data.get("linear_solver"):
            use = dict(data["linear_solver"])
            use["reasons"] = tuple(use.get("reasons", ()))
            common["linear_solver"] = LinearSolverUse(**use)
        common["status"] = Outcome.parse(str(data["status"]))
        common["dofs"] = Dofs(**data["dofs"])
        solve = optimization = None
        if "volume_reference" in data:
            keys = [f.name for f in dataclasses.fields(SolveMeasures)]
            values: dict[str, Any] = {k: data.get(k) for k in keys}
            values["probes"] = tuple(Probe(tuple(p["reference"]), tuple(p["deformed"]))
                                     for p in data.get("probes", ()))
            solve = SolveMeasures(**values)
        if "evaluations" in data:
            keys = [f.name for f in dataclasses.fields(OptimizationMeasures)]
            measured: dict[str, Any] = {k: data.get(k) for k in keys}
            optimization = OptimizationMeasures(**measured)
        verified = verified_from_json(data["verified"]) if data.get("verified") else None
        return cls(**common, solve=solve, optimization=optimization, verified=verified)


def verified_from_json(data: dict[str, Any]) -> Verified:
    """summary.json's (and verify.json's) ``verified`` read back."""
    fields = dict(data)
    lifted = fields.pop("lifted", None)
    stability = _stability(fields.pop("stability", None))
    if lifted:
        lifted = dict(lifted)
        lifted["stability"] = _stability(lifted.get("stability"))
    return Verified(**fields, lifted=Lifted(**lifted) if lifted else None, stability=stability)


def _stability(data: dict[str, Any] | None) -> Stability | None:
    """summary.json's ``stability`` (``stable`` is derived) read back."""
    if not data:
        return None
    fields = {k: v for k, v in data.items() if k != "stable"}
    return Stability(**{**fields, "lowest": tuple(fields["lowest"])})


def _plain(value: Any) -> Any:
    """A dataclass as a mapping (recursively); write_json makes the rest JSON-ready."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    return value


def percent(value: float | None, missing: str = "n/a") -> str:
    """A relative number of a summary (a shape error over the target size) as a percentage
    to three figures, as the commands log it; ``missing`` where there is none."""
    return missing if value is None else f"{100 * value:.3g} %"
