"""Files a run leaves behind: summary.json and fields.xdmf (+ .h5) for ParaView.

XDMF in dolfinx 0.5 stores degree-1 Lagrange fields, so P2 displacements and
degree-2 growth fields are interpolated to P1 for viewing (the solution itself
is not changed).  In ParaView, open fields.xdmf with the "Xdmf3ReaderT" reader
and apply "Warp By Vector" with ``displacement`` to see the deformed body.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import dolfinx.fem
import numpy as np
from mpi4py import MPI

from .. import compat
from ..physics.growth import Growth


def write_json(path: Path, data: dict[str, Any], comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Write ``data`` as JSON on rank 0, atomically (NaN and inf become null)."""
    if comm.rank == 0:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(json.dumps(_clean(data), indent=2) + "\n")
        os.replace(tmp, path)
    comm.barrier()


def read_json(path: Path) -> dict[str, Any]:
    return json.loads(Path(path).read_text())


def _clean(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def to_p1(f: dolfinx.fem.Function, name: str | None = None) -> dolfinx.fem.Function:
    """A degree-1 copy of a scalar or vector Lagrange function."""
    mesh = f.function_space.mesh
    vector = f.function_space.dofmap.index_map_bs > 1
    space = compat.vector_space(mesh, 1) if vector else compat.scalar_space(mesh, 1)
    g = dolfinx.fem.Function(space, name=name or f.name)
    g.interpolate(f)
    return g


def eigenvector_fields(growth: Growth) -> list[dolfinx.fem.Function]:
    """v_1..v_N of C_g as P1 vector fields."""
    space = compat.vector_space(growth.mesh, 1)
    out = []
    for i, v in enumerate(growth.vectors()):
        f = dolfinx.fem.Function(space, name=f"v_{i + 1}")
        compat.interpolate_expression(f, v)
        out.append(f)
    return out


def write_fields(path: Path, displacement: dolfinx.fem.Function, growth: Growth,
                 extra: Sequence[dolfinx.fem.Function] = ()) -> None:
    """fields.xdmf: displacement, growth eigenvalues (and angles), eigenvectors."""
    functions = [to_p1(displacement, "displacement")]
    functions += [to_p1(f) for f in growth.fields]
    functions += eigenvector_fields(growth)
    functions += [to_p1(f) for f in extra]
    compat.write_xdmf(path, displacement.function_space.mesh, functions)


HISTORY_COLUMNS = ("iteration", "objective", "rho_H", "complexity", "hausdorff",
                   "grad_norm", "newton_iterations", "seconds", "alpha", "optimizer_seconds",
                   "level")


def write_history(out: Path, records, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """history.csv (one row per iteration) and history.png (objective against
    iteration, as in the paper's Fig. 4)."""
    if comm.rank == 0 and records:
        out.mkdir(parents=True, exist_ok=True)
        lines = [",".join(HISTORY_COLUMNS)]
        for r in records:
            lines.append(",".join(repr(getattr(r, c)) for c in HISTORY_COLUMNS))
        (out / "history.csv").write_text("\n".join(lines) + "\n")
        # a Figure of its own: no pyplot, so a notebook's backend is left alone
        from matplotlib.figure import Figure

        fig = Figure(figsize=(5.5, 3.6), dpi=120)
        ax = fig.subplots()
        it = [r.iteration for r in records]
        ax.semilogy(it, [r.objective for r in records], "o-", ms=3, label="objective J")
        ax.semilogy(it, [r.hausdorff for r in records], "s--", ms=3, alpha=0.7,
                    label="exact Hausdorff distance")
        ax.set_xlabel("iteration")
        ax.set_ylabel("value")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / "history.png")
    comm.barrier()


def deformation_field(displacement: dolfinx.fem.Function) -> dolfinx.fem.Function:
    """Phi = X + u as a P1 vector field (named Phi)."""
    import ufl

    space = compat.vector_space(displacement.function_space.mesh, 1)
    phi = dolfinx.fem.Function(space, name="Phi")
    compat.interpolate_expression(
        phi, ufl.SpatialCoordinate(space.mesh) + displacement)
    return phi
