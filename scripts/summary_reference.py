"""The reference of summary.json's keys, generated from its types (io/summary.py,
io/records.py, physics/stability.py) into docs/OUTPUTS.md, between its markers.

    .venv/bin/python scripts/summary_reference.py

Every key a summary can hold is a field of one of those frozen dataclasses; MEANING says what
each means, and tests/test_docs.py fails where a field has no meaning here or the page is
stale.
"""

from __future__ import annotations

import dataclasses
import types
import typing
from pathlib import Path

from shapegrowth.io.records import Lifted, Verified
from shapegrowth.io.summary import (
    Dofs,
    LinearSolverUse,
    OptimizationMeasures,
    RunSummary,
    SolveMeasures,
)
from shapegrowth.physics.stability import Stability

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "OUTPUTS.md"
BEGIN = "<!-- summary keys: scripts/summary_reference.py -->"
END = "<!-- /summary keys -->"

# key (dotted where nested) -> what it means
MEANING: dict[str, str] = {
    "name": "the config's `name`",
    "status": "`converged`, `max_iterations`, `solved`, or `failed: <reason>` (exit status 1)",
    "iterations": "optimiser iterations made (0 for `solve`)",
    "objective_initial": "J at the start: the shape term S (+ complexity)",
    "objective_final": "J at the best growth",
    "rho_H_initial": "rho_H (2.9) at the start",
    "rho_H_final": "rho_H at the best growth",
    "hausdorff_initial": "exact Hausdorff distance body-target at the start, on the run's mesh",
    "hausdorff_final": "the same at the best growth: **self-reported** (over `target_size`)",
    "target_size": "the target's largest extent along an axis (a body of revolution's section: "
                   "the revolved body's)",
    "wall_time_s": "the whole command's wall time",
    "time_split": "seconds by part: forward, adjoint, rho_H, optimizer, verification, ...",
    "newton_iterations_total": "Newton iterations of every state solve",
    "continuation_steps": "load steps of the solves from rest",
    "failed_steps": "load steps that failed and were cut",
    "growth_reached": "the fraction of the growth the last solve from rest reached (1: all)",
    "dofs": "the last model's DOFs",
    "dofs.state": "state (displacement) DOFs of the last model",
    "dofs.design": "design DOFs (every design field's nodal values)",
    "mpi_size": "MPI ranks",
    "version": "shapegrowth's version",
    "dolfinx_version": "dolfinx's version",
    "mesh": "the mesh file the run used",
    "config": "the whole config, every default resolved",
    "volume_reference": "`solve`: the body's volume at rest",
    "volume_deformed": "`solve`: its volume deformed",
    "stress_l2": "`solve`: the L2 norm of the first Piola stress",
    "residual_strain": "RMS of abs(A^T A - I), A = F G^-1: 0 where the growth is compatible",
    "probes": "`solve --probe`: each point's `reference` X and `deformed` Phi(X)",
    "evaluations": "`run`: objective evaluations (line searches included)",
    "rho_H_from_rest": "`run`: rho_H of the best growth grown from rest on the run's mesh",
    "hausdorff_from_rest": "`run`: its exact Hausdorff distance (far from `hausdorff_final`: "
                           "another branch)",
    "resumed": "`run`: continued from checkpoint.h5 (`--resume`)",
    "verified": "`run`: **the verified number** ([VERIFICATION.md](VERIFICATION.md)); absent with "
                "`verify.enabled: false`",
    "verified.hausdorff": "exact Hausdorff distance of the best growth grown from rest on the "
                          "refined mesh",
    "verified.relative": "that over the target's size: the run's headline where no lift is made",
    "verified.refine": "refinements of the run's finest mesh it was measured on",
    "verified.dofs": "state DOFs there",
    "verified.wall_s": "the check's wall time",
    "verified.branch_changed": "grown from rest on the run's own mesh, the body reached another "
                               "equilibrium than the run's path",
    "verified.status": "`solved`, or `failed: <reason>`",
    "verified.surface": "`relative` measured surface to surface, without the clouds' sampling",
    "verified.iteration": "`verify.best: verified`: the iteration whose growth this is (null: the "
                          "optimiser's best)",
    "verified.continued_from": "`verify --continued`: the refinement its equilibrium was "
                               "continued from (null: from rest)",
    "verified.lifted": "a section's growth lifted onto its 3D body (`verify.lift`): the headline "
                       "then",
    "verified.stability": "`stability.*` of the verified state",
    "lifted.hausdorff": "exact Hausdorff distance of the 3D body grown from rest",
    "lifted.relative": "that over the 3D target's size: **the headline** of a section",
    "lifted.dofs": "state DOFs of the 3D model",
    "lifted.wall_s": "the lift's wall time",
    "lifted.status": "`solved`, or `failed: <reason>`",
    "lifted.config": "the 3D config's name",
    "lifted.departure": "how far the 3D body leaves the section's equilibrium, over the target's "
                        "size",
    "lifted.surface": "`relative` surface to surface",
    "lifted.continued_from": "as `verified.continued_from`",
    "lifted.stability": "`stability.*` of the 3D body's state",
    "stability": "the tangent's lowest eigenvalues at the state ([STABILITY.md](STABILITY.md)); "
                 "also `verified.stability`, `verified.lifted.stability`",
    "stability.lowest": "the lowest eigenvalues (squared angular frequencies for unit density)",
    "stability.stable": "no negative eigenvalue",
    "stability.negative": "how many eigenvalues are negative",
    "stability.lost_at": "the load fraction where the path from rest first lost stability (null: "
                         "never)",
    "stability.kind": "`bifurcation` or `limit_point`",
    "stability.branch": "`followed` (the path from rest) or `switched` (`solver.branch: switch`)",
    "stability.switched_at": "the load fraction where the solve left the path",
    "peak_memory_mb": "resident memory high-water mark, summed over the ranks",
    "linear_solver": "`solver.linear` as used",
    "linear_solver.preset": "the preset (`auto` resolved on the last model)",
    "linear_solver.fallbacks": "solves that failed with the preset and were done again with LU",
    "linear_solver.state_fallbacks": "of them, state solves",
    "linear_solver.adjoint_fallbacks": "of them, adjoint solves",
    "linear_solver.reasons": "PETSc's reasons of the first fallbacks",
    "linear_solver.reason": "why the preset: named, or `auto`'s rule with the model's size "
                            "and cells across (physics/linear.py)",
    "linear_solver.krylov_solves": "an iterative preset's (`mumps_blr`, `gamg`, `hypre`, "
                                   "`pmg`) state Newton steps solved by it (0 for a "
                                   "factorisation)",
    "linear_solver.krylov_iterations": "their Krylov iterations, in all",
    "fabrication": "`growth.levels`: `fabrication/fabrication.json`, the crisp design's "
                   "materials (null without levels)",
}
# records written under another key than their field's name
_PREFIX = {Lifted: "lifted", Stability: "stability", LinearSolverUse: "linear_solver"}
_FLAT = {SolveMeasures: "solve", OptimizationMeasures: "run"}  # flattened into the top level
_NESTED = (Dofs, Verified, Lifted, Stability, LinearSolverUse)  # written as objects of keys


def _record(hint: object) -> type | None:
    """The dataclass a field holds (through Optional), or None."""
    args = typing.get_args(hint) if isinstance(hint, types.UnionType) or \
        typing.get_origin(hint) is typing.Union else (hint,)
    for a in args:
        if dataclasses.is_dataclass(a):
            return a  # type: ignore[return-value]
    return None


# keys a record's to_json adds beside its fields (a property written out)
_COMPUTED: dict[type, dict[str, list[str]]] = {Stability: {"lowest": ["stable"]}}
# who writes a key and the keys of its record, where not every command does
_WRITER = {"verified": "run", "lifted": "run, lift", "fabrication": "run"}


def keys() -> list[tuple[str, str]]:
    """(key, who writes it) for every key summary.json can hold: the top level first, then
    each object's keys, a record's own once, under its own name (Stability's under
    ``stability``)."""
    out: list[tuple[str, str]] = []
    pending: list[tuple[type, str, str]] = [(RunSummary, "", "both")]
    seen: set[type] = set()
    while pending:
        cls, prefix, writer = pending.pop(0)
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            record = _record(hints[f.name])
            if record in _FLAT:
                pending.insert(0, (record, "", _FLAT[record]))
                continue
            key = f"{prefix}{f.name}"
            known = [i for i, (k, _) in enumerate(out) if k == key]
            if known:  # written by both measures (residual_strain)
                out[known[0]] = (key, "both")
            else:
                out.append((key, _WRITER.get(key, writer)))
            for extra in _COMPUTED.get(cls, {}).get(f.name, []):
                out.append((f"{prefix}{extra}", writer))
            if record in _NESTED and record not in seen:
                seen.add(record)
                name = _PREFIX.get(record, f"{prefix}{f.name}")
                pending.append((record, f"{name}.", _WRITER.get(name, writer)))
    return out


def markdown() -> str:
    rows = ["| key | written by | meaning |", "|---|---|---|"]
    for key, writer in keys():
        rows.append(f"| `{key}` | {writer} | {MEANING[key]} |")
    return "\n".join([BEGIN, *rows, END])


def page() -> str:
    text = PAGE.read_text()
    start, end = text.index(BEGIN), text.index(END) + len(END)
    return text[:start] + markdown() + text[end:]


if __name__ == "__main__":
    PAGE.write_text(page())
    print(f"wrote {PAGE}")
