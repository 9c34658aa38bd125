"""Files a run leaves behind: summary.json and fields.xdmf (+ .h5) for ParaView.

XDMF stores a value at every node of the mesh's geometry, so the fields are interpolated to
Lagrange of the geometry's degree for viewing: P1 on straight simplices (P2 displacements and
degree-2 growth fields lose their mid-edge values there), Q2 on 27-node hexahedra (the
solution itself is not changed).  In ParaView, open fields.xdmf with the "Xdmf3ReaderT" reader
and apply "Warp By Vector" with ``displacement`` to see the deformed body.
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import dolfinx.fem
import numpy as np
import ufl
from mpi4py import MPI

from .. import compat
from ..physics.growth import Growth

log = logging.getLogger(__name__)


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


def viewable(f: dolfinx.fem.Function, name: str | None = None) -> dolfinx.fem.Function:
    """A copy of a scalar or vector Lagrange function of the mesh's geometry degree: degree 1,
    or 2 on a second-order (hexahedral) mesh, whose XDMF holds a value at every node."""
    mesh = f.function_space.mesh
    vector = f.function_space.dofmap.index_map_bs > 1
    degree = compat.geometry_degree(mesh)
    space = compat.vector_space(mesh, degree) if vector else compat.scalar_space(mesh, degree)
    g = dolfinx.fem.Function(space, name=name or f.name)
    g.interpolate(f)
    return g


def eigenvector_fields(growth: Growth) -> list[dolfinx.fem.Function]:
    """v_1..v_N of C_g as vector fields of the mesh's geometry degree (viewable)."""
    space = compat.vector_space(growth.mesh, compat.geometry_degree(growth.mesh))
    vectors = growth.vectors()
    if growth.section is not None:  # a section's 3D frame, seen in its plane
        a, b = growth.section.axes
        vectors = [ufl.as_vector([v[a], v[b]]) for v in vectors]
    out = []
    for i, v in enumerate(vectors):
        f = dolfinx.fem.Function(space, name=f"v_{i + 1}")
        compat.interpolate_expression(f, v)
        out.append(f)
    return out


def write_fields(path: Path, displacement: dolfinx.fem.Function, growth: Growth,
                 extra: Sequence[dolfinx.fem.Function] = ()) -> bool:
    """fields.xdmf: displacement, growth eigenvalues (and angles), eigenvectors.  Whether it
    was written (a writer that fails says so in one warning, collectively)."""
    functions = [viewable(displacement, "displacement")]
    functions += [viewable(f) for f in growth.fields]
    functions += eigenvector_fields(growth)
    functions += [viewable(f) for f in extra]
    try:
        compat.write_xdmf(path, displacement.function_space.mesh, functions)
    except RuntimeError as err:  # dolfinx 0.5.2's pull-back on badly distorted curved cells
        log.warning("%s: not written (%s); the other outputs are", path, err)
        return False
    return True


def write_growth(path: Path, growth: Growth, refine: int) -> None:
    """growth.npz: the growth fields at their nodes, ``points`` (n, 3, mesh coordinates) and
    one array per field (``lambda_hat_1``, ...), gathered on rank 0 in no particular order:
    independent of the ranks that wrote it (``shapegrowth lift`` reads it back), and
    ``refine``, the refinements of the config's mesh the fields live on (a run's last level)."""
    comm = growth.mesh.comm
    owned = growth.space.dofmap.index_map.size_local
    points = comm.gather(growth.space.tabulate_dof_coordinates()[:owned], root=0)
    values = [comm.gather(f.x.array[:owned], root=0) for f in growth.fields]
    if comm.rank == 0:
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays: dict[str, Any] = {f.name: np.concatenate(v)
                                  for f, v in zip(growth.fields, values)}
        with open(path.with_suffix(".tmp"), "wb") as tmp:
            np.savez(tmp, points=np.concatenate(points), refine=refine, **arrays)
        os.replace(path.with_suffix(".tmp"), path)
    comm.barrier()


def growth_refinements(path: Path) -> int:
    """The ``refine`` a growth.npz was written with."""
    return int(np.load(path)["refine"])


def read_growth(path: Path, growth: Growth, partial: bool = False) -> list[str]:
    """Set ``growth``'s fields from a growth.npz written on the same mesh (any ranks): each
    node takes the value stored at its coordinates.  ValueError when the file does not
    match the mesh.  ``partial``: fields the file lacks keep their values (a fixed frame's
    eigenvalues read into a free frame, whose angles stay); the names set are returned."""
    data = np.load(path)
    from scipy.spatial import cKDTree

    coords = growth.space.tabulate_dof_coordinates()
    distance, index = cKDTree(data["points"]).query(coords)
    scale = max(float(np.abs(data["points"]).max(initial=0.0)), 1.0)
    local_bad = int(np.count_nonzero(distance > 1e-9 * scale))
    names = [f.name for f in growth.fields]
    missing = [n for n in names if n not in data.files]
    if partial and len(missing) < len(names):
        missing = []
    # every stored node is one of the mesh's (a nested coarser mesh matches a subset)
    if growth.mesh.comm.allreduce(local_bad) or missing \
            or compat.global_size(growth.space) != len(data["points"]):
        raise ValueError(f"{path} does not hold this model's growth (other mesh or fields: "
                         f"{missing or 'nodes do not match'})")
    found = [f for f in growth.fields if f.name in data.files]
    for f in found:
        f.x.array[:] = data[f.name][index]
    return [f.name for f in found]


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
