"""The target shape as a weighted point cloud.

* ``target: {map: [...]}``: the points Phi_d(X_q) at the body's reference
  quadrature points with the weights w_q |det grad Phi_d(X_q)|, the target's own
  volume measure (``target.weights: volume``): a body that takes the target shape
  then has exactly the target's cloud, points and weights.  Where det grad Phi_d = 0
  (the targets of scenes 2 and 5 do not depend on one coordinate and have no volume)
  that measure vanishes, and the push-forward of the reference measure (weights w_q)
  is used there; ``target.weights: pushforward`` uses it everywhere.
* ``target: {mesh: file}``: the quadrature points of the target mesh's cells with
  their physical weights (gmsh .msh through gmsh; other formats through meshio
  when it is installed).  Each rank takes a contiguous share of the cells.
* ``target: {surface: file}``: a surface (STL, OBJ, PLY, OFF, .msh triangles), repaired
  where that is safe (surface_repair.py); closed, filled with tetrahedra by gmsh
  (surface_files.py) and sampled like a mesh, or sampled as a surface against a face.
* ``target.transform`` places a mesh or surface file (placement.py): scaled, rotated,
  translated, and optionally aligned by principal axes onto the body's reference.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from mpi4py import MPI

from .. import compat
from ..config import Config, ConfigError, TransformConfig, resolved
from ..config.expressions import evaluate
from ..config.maps import map_jacobian, target_gradient
from .clouds import QuadratureCloud
from .facet_clouds import FacetCloud
from .hausdorff import PointCloud
from .placement import affine, best_fit, principal_alignment
from .surface_files import filled_surface, surface_triangles


def target_cloud(cfg: Config, cloud: QuadratureCloud | FacetCloud,
                 comm: MPI.Comm) -> PointCloud:
    target = cfg.target
    if target is None:
        raise ConfigError(["target: required for this command (give map: or mesh:)"])
    if target.map is not None:
        points, X = mapped_points(cfg, cloud.X)
        if isinstance(cloud, FacetCloud):  # the face's image, its area measure (Nanson)
            return PointCloud(points, cloud.w * _section_area(cfg, X, cloud.N))
        return PointCloud(points, cloud.w * map_jacobian(cfg, X, target.weights))
    if isinstance(cloud, FacetCloud):  # a face against a surface, open or closed
        if target.surface is None:  # the config's checks say so first
            raise ConfigError(["objective.compare: a face is compared with a target.map or "
                               "a target.surface"])
        return surface_target(cfg, cloud, comm)[0]
    if target.surface is not None:
        nodes, cells = filled_surface(Path(target.surface), target.pieces, target.crop)
    else:
        nodes, cells = _read_simplices(Path(resolved(target.mesh)), cfg.dim)
    return file_cloud(nodes, cells, cloud, target.transform, comm)


def mapped_points(cfg: Config, X_mesh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """target.map's image (n, gdim) of the mesh points X_mesh (n, gdim), and the 3D points
    (3, n) they stand for (a section's points stand for the 3D body's)."""
    target, section = resolved(cfg.target), cfg.section
    X = np.zeros((3, len(X_mesh)))
    X[:X_mesh.shape[1]] = X_mesh.T
    if section.reduced:  # the 3D points the section stands for; the map is the 3D body's
        X = section.embed(X)
    params, axis = cfg.expression_params, cfg.cylinder_axis
    points = np.column_stack([evaluate(e, X, params, axis) for e in resolved(target.map)])
    if not np.isfinite(points).all():
        raise ConfigError(["target.map: the map is not finite everywhere on the body"])
    if section.reduced:
        points = section.in_plane(points)
    return points, X


def surface_target(cfg: Config, cloud: FacetCloud,
                   comm: MPI.Comm) -> tuple[PointCloud, np.ndarray, np.ndarray]:
    """target.surface against a face: its cloud (this rank's share), its nodes as
    target.transform places them against ``cloud`` and its triangles (whole, every rank)."""
    target = resolved(cfg.target)
    nodes, cells = surface_triangles(Path(resolved(target.surface)), target.pieces,
                                     target.crop)
    nodes = _placed(nodes, cells, cloud, target.transform, comm)
    return _share(nodes, cells, cloud.degree, comm), nodes, cells


def _section_area(cfg: Config, X: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """The face's area factor under target.map at the 3D points X: a plane section's edge
    by the map's in-plane block, a meridian's edge by the 3D map on the surface it sweeps
    (its tangent and the hoop direction: |G t| r/R for a map of revolution)."""
    grad, section = target_gradient(cfg, X), cfg.section
    if not section.reduced:
        return mapped_area(grad, normals)
    if section.axisymmetric:
        return mapped_area(grad, section.embed(normals.T).T)
    axes = list(section.axes)
    return mapped_area(grad[:, axes][:, :, axes], normals)


def mapped_area(grad: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """|cof(G) N|: the area of a face element of unit normal N under a map of gradient G
    (n, d, d), as |G t1 x G t2| (3D) or |G t| (2D) with t the unit tangents of N, which holds
    where G has no volume too (scenes 2 and 5's maps)."""
    if normals.shape[1] == 2:
        t = np.column_stack([-normals[:, 1], normals[:, 0]])
        return np.linalg.norm(np.einsum("nij,nj->ni", grad, t), axis=1)
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.cross(normals, helper)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    t2 = np.cross(normals, t1)
    return np.linalg.norm(np.cross(np.einsum("nij,nj->ni", grad, t1),
                                   np.einsum("nij,nj->ni", grad, t2)), axis=1)


def file_cloud(nodes: np.ndarray, cells: np.ndarray, cloud: QuadratureCloud | FacetCloud,
               transform: TransformConfig, comm: MPI.Comm) -> PointCloud:
    """The cloud of a file's simplices (whole on every rank) placed by ``transform``: each
    rank takes a contiguous share of the cells, sampled at ``cloud``'s degree."""
    return _share(_placed(nodes, cells, cloud, transform, comm), cells, cloud.degree, comm)


def rank_share(n: int, comm: MPI.Comm) -> slice:
    """This rank's contiguous share of n items that every rank holds whole."""
    return slice(n * comm.rank // comm.size, n * (comm.rank + 1) // comm.size)


def _share(nodes: np.ndarray, cells: np.ndarray, degree: int, comm: MPI.Comm) -> PointCloud:
    """The cloud of this rank's contiguous share of the cells."""
    return simplex_cloud(nodes, cells[rank_share(len(cells), comm)], degree)


def _placed(nodes: np.ndarray, cells: np.ndarray, cloud: QuadratureCloud | FacetCloud,
            transform: TransformConfig, comm: MPI.Comm) -> np.ndarray:
    """A file's nodes placed by ``transform`` (aligned onto ``cloud``'s reference)."""
    if not transform.identity:
        nodes = affine(nodes, transform)
    if transform.align != "none":
        whole = simplex_cloud(nodes, cells, cloud.degree)
        body = cloud.reference()
        points = np.concatenate(comm.allgather(body.points))
        weights = np.concatenate(comm.allgather(body.weights))
        if transform.align == "principal_axes":
            R, t = principal_alignment((whole.points, whole.weights), (points, weights))
        else:  # best_fit: to a face's tangent planes, or to the volume's points
            normals = np.concatenate(comm.allgather(cloud.N)) \
                if isinstance(cloud, FacetCloud) else None
            R, t = best_fit((whole.points, whole.weights), (points, weights), normals)
        nodes = nodes @ R.T + t
    return nodes


def simplex_cloud(nodes: np.ndarray, cells: np.ndarray, degree: int) -> PointCloud:
    """Quadrature points and weights of simplices (n, k + 1) on ``nodes`` (n, dim): volumes
    (k = dim) or, for the triangles of a surface in 3D (k < dim), their areas."""
    dim, k = nodes.shape[1], cells.shape[1] - 1
    ref_points, ref_weights = compat.simplex_quadrature(k, degree)
    v0 = nodes[cells[:, 0]]
    jac = np.stack([nodes[cells[:, j + 1]] - v0 for j in range(k)], axis=2)  # (n, dim, k)
    points = v0[:, None, :] + np.einsum("cij,qj->cqi", jac, ref_points)
    if k == dim:
        measure = np.abs(np.linalg.det(jac))
    else:  # the Gram determinant
        measure = np.sqrt(np.abs(np.linalg.det(np.einsum("cik,cil->ckl", jac, jac))))
    weights = measure[:, None] * ref_weights[None, :]
    return PointCloud(points.reshape(-1, dim), weights.ravel())


def _read_simplices(path: Path, dim: int) -> tuple[np.ndarray, np.ndarray]:
    if not path.is_file():
        raise ConfigError([f"target.mesh: file '{path}' not found"])
    if path.suffix == ".msh":
        import gmsh

        gmsh.initialize()
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            gmsh.merge(str(path))
            tags, coords, _ = gmsh.model.mesh.getNodes()
            index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
            index[tags.astype(np.int64)] = np.arange(len(tags))
            gmsh_type = 4 if dim == 3 else 2  # linear tetrahedra / triangles
            _, node_tags = gmsh.model.mesh.getElementsByType(gmsh_type)
        finally:
            gmsh.finalize()
        nodes = coords.reshape(-1, 3)[:, :dim]
        cells = index[node_tags.astype(np.int64)].reshape(-1, dim + 1)
    else:
        try:
            import meshio
        except ImportError:
            raise ConfigError([f"target.mesh: '{path.suffix}' files need meshio "
                               "(pip install meshio), or give a gmsh .msh file"]) from None
        mesh = meshio.read(path)
        kind = "tetra" if dim == 3 else "triangle"
        blocks = [c.data for c in mesh.cells if c.type == kind]
        if not blocks:
            raise ConfigError([f"target.mesh: '{path}' holds no {kind} cells"])
        nodes, cells = mesh.points[:, :dim], np.concatenate(blocks)
    if len(cells) == 0:
        raise ConfigError([f"target.mesh: '{path}' holds no {dim}D simplices"])
    return np.ascontiguousarray(nodes, dtype=float), cells.astype(np.int64)
