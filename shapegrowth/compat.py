"""The dolfinx-version-specific calls, gathered so a newer dolfinx is a local change.

Three releases are served and tested: dolfinx 0.5.2 (Debian 12, ufl 2022.2, PETSc 3.18),
dolfinx 0.9.0 (Debian 13, ufl 2024.2, basix 0.9, PETSc 3.22) and dolfinx 0.11.0 (the pip
wheel ``dolfinx-solver-real``: ufl 2026.1, basix 0.11, PETSc 3.25; ``make
test-dolfinx011``).  Every difference is a branch in this module on ``AT_LEAST_0_9``,
``AT_LEAST_0_10`` (where 0.10 made the change) or ``AT_LEAST_0_11``
(where only 0.11 was seen to differ), each with a comment naming the release; the rest of
the package calls these helpers for meshes from gmsh, function spaces, PETSc vectors of
functions, boundary conditions, expression evaluation, point evaluation and XDMF output.
The releases between (0.6-0.8, 0.10) are not tested.  The wheel's own libhdf5, which
h5py must not bind to, is handled here too.
"""

from __future__ import annotations

import functools
import importlib
from pathlib import Path
from typing import Any

import basix
import dolfinx
import dolfinx.cpp
import dolfinx.fem
import dolfinx.fem.petsc  # noqa: F401  (registers dolfinx.fem.petsc)
import dolfinx.geometry
import dolfinx.io
import dolfinx.la
import numpy as np
import ufl
from mpi4py import MPI

DOLFINX_VERSION = dolfinx.__version__
AT_LEAST_0_9 = tuple(int(p) for p in DOLFINX_VERSION.split(".")[:2]) >= (0, 9)
AT_LEAST_0_10 = tuple(int(p) for p in DOLFINX_VERSION.split(".")[:2]) >= (0, 10)
AT_LEAST_0_11 = tuple(int(p) for p in DOLFINX_VERSION.split(".")[:2]) >= (0, 11)


def read_gmsh(path: Path, comm: MPI.Comm, gdim: int):
    """(mesh, cell_tags, facet_tags) from a gmsh .msh file read on rank 0.

    Debian's dolfinx 0.5.2 ``gmshio.read_from_msh`` returns an undefined name,
    so the file is merged here and handed to ``model_to_mesh``.
    """
    import gmsh

    # 0.10 renamed dolfinx.io.gmshio to dolfinx.io.gmsh
    gmshio: Any = importlib.import_module("dolfinx.io.gmsh" if AT_LEAST_0_10
                                          else "dolfinx.io.gmshio")
    if comm.rank == 0:
        gmsh.initialize()
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.merge(str(path))
    if AT_LEAST_0_10:  # 0.10 asks for the ghost mode and the facet's most cells
        partitioner = dolfinx.cpp.mesh.create_cell_partitioner(
            _ordered_partition, dolfinx.cpp.mesh.GhostMode.none, 2)
    else:
        partitioner = dolfinx.cpp.mesh.create_cell_partitioner(_ordered_partition)
    if AT_LEAST_0_9:  # 0.6 added model_to_mesh(..., partitioner=)
        try:
            data = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=gdim,
                                        partitioner=partitioner)
            if AT_LEAST_0_10:  # 0.10: a MeshData, not (mesh, cell_tags, facet_tags)
                return data.mesh, data.cell_tags, data.facet_tags
            return data
        finally:
            if comm.rank == 0:
                gmsh.finalize()
    # model_to_mesh takes no partitioner in 0.5.2: hand it a create_mesh that uses ours
    default_create_mesh = gmshio.create_mesh
    gmshio.create_mesh = functools.partial(default_create_mesh, partitioner=partitioner)
    try:
        return gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=gdim)
    finally:
        gmshio.create_mesh = default_create_mesh
        if comm.rank == 0:
            gmsh.finalize()


def _ordered_partition(comm, nparts: int, graph, ghosting: bool):
    """A reproducible partition of the cells (the default, PT-SCOTCH, gave the tube mesh
    485/491 owned DOFs in one build and 475/501 in the next, so runs were not repeatable and
    a checkpoint's design did not fit another build).  The rank holding the cells orders
    them by reverse Cuthill-McKee on the dual graph (neighbours stay close) and cuts the
    order into ``nparts`` equal blocks; with ghosting, a cell is also sent to the owners of
    its facet neighbours."""
    import scipy.sparse
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    offsets, targets = np.asarray(graph.offsets), np.asarray(graph.array)
    n = len(offsets) - 1
    if n == 0:
        return dolfinx.cpp.graph.AdjacencyList_int32(np.zeros(0, dtype=np.int32),
                                                     np.zeros(1, dtype=np.int32))
    first = comm.exscan(n) if comm.rank > 0 else 0
    rows = np.repeat(np.arange(n), np.diff(offsets))
    local = (targets >= first) & (targets < first + n)
    adjacency = scipy.sparse.csr_matrix(
        (np.ones(int(local.sum())), (rows[local], targets[local] - first)), shape=(n, n))
    order = reverse_cuthill_mckee(adjacency, symmetric_mode=True)
    owner = np.empty(n, dtype=np.int32)
    owner[order] = (np.arange(n) * nparts) // n
    if not ghosting or nparts == 1:
        return dolfinx.cpp.graph.AdjacencyList_int32(owner.reshape(-1, 1))
    neighbour_owner = owner[targets[local] - first]
    dest: list[list[int]] = [[int(p)] for p in owner]
    for cell, other in zip(rows[local], neighbour_owner):
        if other != owner[cell] and other not in dest[cell]:
            dest[cell].append(int(other))
    lengths = np.array([len(d) for d in dest])
    return dolfinx.cpp.graph.AdjacencyList_int32(
        np.concatenate(dest).astype(np.int32),
        np.concatenate([[0], np.cumsum(lengths)]).astype(np.int32))


def simplex_quadrature(dim: int, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Points and weights of basix's default quadrature of ``degree`` on the reference
    triangle (dim 2) or tetrahedron (dim 3)."""
    cell = basix.CellType.tetrahedron if dim == 3 else basix.CellType.triangle
    return basix.make_quadrature(cell, degree)


def reference_quadrature(mesh, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Points and weights of basix's default quadrature of ``degree`` on the mesh's reference
    cell: triangle, tetrahedron, quadrilateral or hexahedron (0.5.2's CellType names them as
    basix does; later dolfinx has ``mesh.basix_cell()``)."""
    cell = getattr(basix.CellType, mesh.topology.cell_type.name)  # 0.9 has no string_to_type
    return basix.make_quadrature(cell, degree)


def space_degree(space) -> int:
    """The polynomial degree of a Lagrange space's element."""
    element = space.ufl_element()
    if AT_LEAST_0_9:  # 0.7: a basix.ufl element, its degree a property
        return int(element.degree)
    return int(element.degree())


def geometry_degree(mesh) -> int:
    """The degree of the mesh's coordinate element (2 for 27-node hexahedra)."""
    cmap = mesh.geometry.cmaps[0] if AT_LEAST_0_11 else mesh.geometry.cmap  # 0.11: cmaps
    return int(cmap.degree)


def vector_space(mesh, degree: int, components: int | None = None):
    """Continuous Lagrange vectors of ``components`` (the mesh's geometric dimension
    where None)."""
    size = mesh.geometry.dim if components is None else components
    if AT_LEAST_0_9:  # 0.7 replaced VectorFunctionSpace by functionspace with a shape
        return dolfinx.fem.functionspace(mesh, ("Lagrange", degree, (size,)))
    return dolfinx.fem.VectorFunctionSpace(mesh, ("CG", degree), dim=size)


def mixed_space(mesh, degree: int):
    """Taylor-Hood: continuous Lagrange vectors of ``degree`` and a scalar of ``degree - 1``
    (the displacement and the pressure of the mixed formulation)."""
    if AT_LEAST_0_9:  # 0.7 moved elements from ufl to basix.ufl
        import basix.ufl
        cell = mesh.basix_cell()
        element = basix.ufl.mixed_element([
            basix.ufl.element("Lagrange", cell, degree, shape=(mesh.geometry.dim,)),
            basix.ufl.element("Lagrange", cell, degree - 1)])
        return dolfinx.fem.functionspace(mesh, element)
    cell = mesh.ufl_cell()
    return dolfinx.fem.FunctionSpace(mesh, ufl.MixedElement(
        [ufl.VectorElement("CG", cell, degree), ufl.FiniteElement("CG", cell, degree - 1)]))


def shell_space(mesh, degree: int):
    """A shell's unknowns over a plane region: the displacement, 3 components of Lagrange
    ``degree`` enriched by the cubic bubble, and the director's 2 angles, Lagrange
    ``degree`` (FEniCSx-Shells' nonlinear Naghdi element)."""
    if AT_LEAST_0_9:  # 0.7 moved elements from ufl to basix.ufl
        import basix.ufl
        cell = mesh.basix_cell()
        enriched = basix.ufl.enriched_element([
            basix.ufl.element("Lagrange", cell, degree), basix.ufl.element("Bubble", cell, 3)])
        element = basix.ufl.mixed_element([
            basix.ufl.blocked_element(enriched, shape=(3,)),
            basix.ufl.element("Lagrange", cell, degree, shape=(2,))])
        return dolfinx.fem.functionspace(mesh, element)
    cell = mesh.ufl_cell()
    enriched = ufl.EnrichedElement(ufl.FiniteElement("Lagrange", cell, degree),
                                   ufl.FiniteElement("Bubble", cell, 3))
    return dolfinx.fem.FunctionSpace(mesh, ufl.MixedElement(
        [ufl.VectorElement(enriched, dim=3),
         ufl.VectorElement("Lagrange", cell, degree, dim=2)]))


def scalar_space(mesh, degree: int, family: str = "Lagrange"):
    """Scalar ``family`` ("Lagrange" or "DG") of ``degree``."""
    if AT_LEAST_0_9:  # 0.7: functionspace (FunctionSpace is the class, not a factory)
        return dolfinx.fem.functionspace(mesh, (family, degree))
    return dolfinx.fem.FunctionSpace(mesh, ("CG" if family == "Lagrange" else family, degree))


def quadrature_space(mesh, degree: int, vector: bool = False):
    """The quadrature space of ``degree`` (basix's default scheme), scalar or a vector of
    the geometric dimension."""
    if AT_LEAST_0_9:  # 0.7 moved elements from ufl to basix.ufl
        import basix.ufl
        shape = (mesh.geometry.dim,) if vector else ()
        element = basix.ufl.quadrature_element(mesh.basix_cell(), value_shape=shape,
                                               scheme="default", degree=degree)
        return dolfinx.fem.functionspace(mesh, element)
    family = ufl.VectorElement if vector else ufl.FiniteElement
    return dolfinx.fem.FunctionSpace(
        mesh, family("Quadrature", mesh.ufl_cell(), degree, quad_scheme="default"))


def create_mesh(comm: MPI.Comm, cells: np.ndarray, x: np.ndarray, cell: str,
                degree: int = 1):
    """A simplex mesh of ``cell`` ("triangle"/"tetrahedron") from arrays, of geometric
    dimension x.shape[1] (a triangle mesh of a surface in space where it is 3) and
    Lagrange geometry of ``degree`` (cells' nodes in DOLFINx's order: vertices, then
    edges)."""
    gdim = x.shape[1]
    if AT_LEAST_0_9:  # 0.7: the coordinate element is a basix.ufl element
        import basix.ufl
        domain = ufl.Mesh(basix.ufl.element("Lagrange", cell, degree, shape=(gdim,)))
    else:
        domain = ufl.Mesh(ufl.VectorElement(
            "Lagrange", ufl.Cell(cell, geometric_dimension=gdim), degree))
    if AT_LEAST_0_9:  # 0.10 put the element before the points: named, as 0.9 names them
        return dolfinx.mesh.create_mesh(comm, cells, e=domain, x=x)
    return dolfinx.mesh.create_mesh(comm, cells, x, domain)


def h5py() -> Any:
    """The h5py module, its compiled parts bound to their own libhdf5.

    dolfinx 0.11's pip wheel carries a libhdf5 (1.10) that ``dolfinx.fem.petsc`` brings into
    the process's global symbol scope; h5py's wheel carries its own (1.14), and imported
    after that its extensions bind to the global one ("Not a datatype" at import).  Loaded
    with RTLD_DEEPBIND each binds to the library it was built with, on every platform."""
    import os
    import sys

    if "h5py" in sys.modules:
        return sys.modules["h5py"]
    flags = sys.getdlopenflags()
    sys.setdlopenflags(flags | getattr(os, "RTLD_DEEPBIND", 0))
    try:
        return importlib.import_module("h5py")
    finally:
        sys.setdlopenflags(flags)


def constant(mesh, value: float) -> dolfinx.fem.Constant:
    """A real constant on ``mesh`` in PETSc's scalar type (petsc4py 3.25's type hints make
    ``PETSc.ScalarType`` a dtype, not a callable type)."""
    from petsc4py import PETSc

    return dolfinx.fem.Constant(mesh, np.asarray(value, dtype=PETSc.ScalarType)[()])


def geometry_nodes(mesh) -> np.ndarray:
    """Geometry node indices of the local cells, one row per cell."""
    if AT_LEAST_0_11:  # 0.11: one dofmap per cell type (mixed-topology meshes)
        return np.asarray(mesh.geometry.dofmaps[0])
    dofmap = mesh.geometry.dofmap
    if AT_LEAST_0_9:  # 0.7 made the geometry dofmap a 2D array
        return np.asarray(dofmap)
    return dofmap.array.reshape(-1, dofmap.offsets[1] - dofmap.offsets[0])


def petsc_vec(f: dolfinx.fem.Function):
    """The PETSc vector that shares ``f``'s values (ghosts included)."""
    if AT_LEAST_0_9:  # 0.8 removed Function.vector for Function.x.petsc_vec
        return f.x.petsc_vec
    return f.vector


def set_bc(b, bcs, x0=None, alpha: float = 1.0) -> None:
    """b <- alpha (g - x0) on the prescribed DOFs."""
    if AT_LEAST_0_9:  # 0.8 renamed scale to alpha
        dolfinx.fem.petsc.set_bc(b, bcs, x0, alpha=alpha)
    else:
        dolfinx.fem.petsc.set_bc(b, bcs, x0, scale=alpha)


def apply_lifting(b, forms, bcs, x0, alpha: float = 1.0) -> None:
    """b <- b - alpha A (g - x0) for the prescribed DOFs of each form's bcs."""
    if AT_LEAST_0_9:  # 0.8 renamed scale to alpha
        dolfinx.fem.petsc.apply_lifting(b, forms, bcs=bcs, x0=x0, alpha=alpha)
    else:
        dolfinx.fem.petsc.apply_lifting(b, forms, bcs=bcs, x0=x0, scale=alpha)


def expression_evaluator(expr: ufl.core.expr.Expr, points: np.ndarray, mesh, cells: np.ndarray):
    """A function returning the values of ``expr`` at the reference ``points`` of
    ``cells`` (one row per cell), compiled once."""
    compiled = dolfinx.fem.Expression(expr, points)
    cells = np.asarray(cells, dtype=np.int32)
    if AT_LEAST_0_9:  # 0.8: Expression.eval(mesh, entities)
        return lambda: compiled.eval(mesh, cells)
    return lambda: compiled.eval(cells)


def evaluate_expression(expr: ufl.core.expr.Expr, points: np.ndarray, mesh,
                        cells: np.ndarray) -> np.ndarray:
    """The values of ``expr`` at the reference ``points`` of ``cells`` (one row per cell)."""
    return expression_evaluator(expr, points, mesh, cells)()


def has_domain(expr: ufl.core.expr.Expr) -> bool:
    """Whether ``expr`` lives on a mesh (a constant expression does not)."""
    from ufl.domain import extract_unique_domain
    return extract_unique_domain(expr) is not None


def create_vector(form):
    """A ghosted PETSc vector for the test space of the linear ``form`` (0.10 takes the
    space, earlier releases the form)."""
    if AT_LEAST_0_10:
        return dolfinx.fem.petsc.create_vector(form.function_spaces[0])
    return dolfinx.fem.petsc.create_vector(form)


def assemble_matrix(form, bcs, diagonal: float = 1.0):
    """The assembled PETSc matrix of the bilinear ``form``, the rows and columns of the
    prescribed DOFs zero but for ``diagonal`` on the diagonal (0.10 renamed the keyword
    ``diagonal`` to ``diag``)."""
    if AT_LEAST_0_10:
        return dolfinx.fem.petsc.assemble_matrix(form, bcs=bcs, diag=diagonal)
    return dolfinx.fem.petsc.assemble_matrix(form, bcs=bcs, diagonal=diagonal)


def interpolation_matrix(coarse, fine):
    """The PETSc matrix that interpolates functions of the space ``coarse`` into ``fine`` on
    the same mesh (P1 into P2, Q1 into Q2; blocked spaces row-blocked alike): the
    prolongation of a p-multigrid.  0.10 put it in dolfinx.fem.petsc; before, the C++
    layer's takes the C++ spaces."""
    if AT_LEAST_0_10:
        return importlib.import_module("dolfinx.fem.petsc").interpolation_matrix(coarse, fine)
    cpp = importlib.import_module("dolfinx.cpp.fem.petsc")
    return cpp.interpolation_matrix(coarse._cpp_object, fine._cpp_object)


def index_map_vector(index_map, bs: int):
    """A ghosted PETSc vector of the DOF layout ``index_map`` with block size ``bs`` (0.10
    moved dolfinx.la.create_petsc_vector to dolfinx.la.petsc.create_vector)."""
    if AT_LEAST_0_11:  # 0.11: a sequence of (index map, block size) pairs
        return importlib.import_module("dolfinx.la.petsc").create_vector([(index_map, bs)])
    if AT_LEAST_0_10:
        return importlib.import_module("dolfinx.la.petsc").create_vector(index_map, bs)
    return dolfinx.la.create_petsc_vector(index_map, bs)


def interpolation_points(space) -> np.ndarray:
    """Reference points at which ``space`` interpolates (for fem.Expression)."""
    points = space.element.interpolation_points
    return points if AT_LEAST_0_10 else points()  # 0.10: a property, no longer a method


def interpolate_expression(target: dolfinx.fem.Function, expr: ufl.core.expr.Expr) -> None:
    """target <- interpolation of a UFL expression (which may be a constant)."""
    if not has_domain(expr):  # a constant: fem.Expression needs a mesh
        values = np.array([float(c) for c in expr] if expr.ufl_shape else [float(expr)])
        target.interpolate(lambda x: np.outer(values, np.ones(x.shape[1])))
        return
    compiled = dolfinx.fem.Expression(expr, interpolation_points(target.function_space))
    target.interpolate(compiled)




def global_size(space) -> int:
    index_map = space.dofmap.index_map
    return index_map.size_global * space.dofmap.index_map_bs




def evaluate_at_points(u: dolfinx.fem.Function, points: np.ndarray) -> np.ndarray:
    """Values of ``u`` at reference points (n, 3), gathered on every rank.

    A point found on several ranks (on a partition boundary) is taken from the
    lowest rank; a point outside the mesh gives NaN.
    """
    return evaluate_near(u, points, points)


def evaluate_near(u: dolfinx.fem.Function, points: np.ndarray, inside: np.ndarray
                  ) -> np.ndarray:
    """Values of ``u`` at points (n, 3), each on the cell that holds ``inside[i]`` (its
    polynomial continued a little past the cell where the point lies outside the mesh),
    gathered on every rank (a point found on several ranks taken from the lowest); NaN
    where ``inside[i]`` is outside the mesh."""
    mesh = u.function_space.mesh
    comm = mesh.comm
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    inside = np.asarray(inside, dtype=np.float64).reshape(-1, 3)
    value_size = u.function_space.dofmap.index_map_bs
    if AT_LEAST_0_9:  # 0.7: bb_tree and compute_collisions_points
        tree = dolfinx.geometry.bb_tree(mesh, mesh.topology.dim)
        candidates = dolfinx.geometry.compute_collisions_points(tree, inside)
    else:
        tree = dolfinx.geometry.BoundingBoxTree(mesh, mesh.topology.dim)
        candidates = dolfinx.geometry.compute_collisions(tree, inside)
    colliding = dolfinx.geometry.compute_colliding_cells(mesh, candidates, inside)
    local = np.full((len(points), value_size), np.nan)
    found = [i for i in range(len(points)) if len(colliding.links(i))]
    if found:
        cells = np.array([colliding.links(i)[0] for i in found], dtype=np.int32)
        local[found] = u.eval(points[found], cells).reshape(len(found), value_size)
    gathered = comm.allgather(local)
    result = np.full_like(local, np.nan)
    for values in gathered:
        fill = np.isnan(result[:, 0]) & ~np.isnan(values[:, 0])
        result[fill] = values[fill]
    return result


def write_xdmf(path: Path, mesh, functions: list[dolfinx.fem.Function]) -> None:
    """One XDMF file (+ .h5) with the mesh and P1 functions, readable by ParaView.
    RuntimeError on every rank, before anything is written, where dolfinx 0.5.2 could not
    write the values of a curved mesh (see :func:`_point_values_fail`)."""
    if functions and not AT_LEAST_0_9 and geometry_degree(mesh) > 1:
        if mesh.comm.allreduce(_point_values_fail(functions[0]), MPI.LOR):
            raise RuntimeError("Newton method failed to converge for non-affine geometry "
                               "(the pull-back of a curved cell's nodes)")
    path.parent.mkdir(parents=True, exist_ok=True)
    with dolfinx.io.XDMFFile(mesh.comm, str(path), "w") as xdmf:
        xdmf.write_mesh(mesh)
        for f in functions:
            xdmf.write_function(f)


def _point_values_fail(u: dolfinx.fem.Function) -> bool:
    """Whether dolfinx 0.5.2's XDMF writer fails on this rank: it evaluates each function
    at every geometry node in the last local cell holding it, pulling the node back by
    Newton's method, which fails on a badly distorted curved cell.  It raises on the ranks
    that hold one while the others enter the file's collective write (a hang), so the same
    evaluation is tried here first and the ranks agree."""
    mesh = u.function_space.mesh
    nodes = geometry_nodes(mesh)
    cells = np.full(len(mesh.geometry.x), -1, dtype=np.int32)
    # the last cell wins, as in the writer's loop (numpy's assignment keeps the last value)
    cells[nodes.ravel()] = np.repeat(np.arange(len(nodes), dtype=np.int32), nodes.shape[1])
    try:
        u.eval(mesh.geometry.x, cells)
    except RuntimeError:
        return True
    return False


def set_option(opts, key: str, value) -> None:
    """Set a PETSc option from a config value: true is a bare flag, false removes it."""
    if value is False:
        opts.delValue(key)
    else:
        opts[key] = "" if value is True else value


def entities_to_geometry(mesh, dim: int, entities: np.ndarray) -> np.ndarray:
    """Geometry node indices of mesh entities (Debian's dolfinx.mesh.Mesh wraps the C++
    mesh in ``_mesh`` instead of deriving from it)."""
    cpp = getattr(mesh, "_mesh", getattr(mesh, "_cpp_object", mesh))
    return dolfinx.cpp.mesh.entities_to_geometry(cpp, dim, np.asarray(entities, np.int32),
                                                 False)


def atan2(y: Any, x: Any) -> Any:
    """UFL's two-argument arctangent: ``atan_2`` in UFL 2022-2023, ``atan2`` after."""
    fn = getattr(ufl, "atan2", None) or getattr(ufl, "atan_2")  # noqa: B009
    return fn(y, x)
