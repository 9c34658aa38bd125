"""gmsh geometries: placement, named boundaries and volumes, serial and distributed."""

from __future__ import annotations

import math

import dolfinx.fem
import numpy as np
import pytest
import ufl
from mpi4py import MPI

from shapegrowth import compat
from shapegrowth.config import BOUNDARIES, from_dict
from shapegrowth.physics.boundary import body_box
from shapegrowth.physics.geometry import load_domain, mesh_path

R, T, L = 0.5, 0.1, 1.0
CASES = {
    "box": ({"length": 1.0, "width": 0.2, "thickness": 0.1}, 0.1, 1.0 * 0.2 * 0.1,
            {"x1_min": 0.02, "x3_max": 0.2}, ([0, -0.1, -0.05], [1.0, 0.1, 0.05])),
    "tube": ({"length": L, "radius": R, "thickness": T}, 0.1, math.pi * (R**2 - (R - T) ** 2) * L,
             {"x1_min": math.pi * (R**2 - (R - T) ** 2), "outer": 2 * math.pi * R * L,
              "inner": 2 * math.pi * (R - T) * L}, ([0, -R, -R], [L, R, R])),
    "annulus": ({"radius": 1.0, "inner_radius": 0.3, "thickness": 0.05}, 0.1,
                math.pi * (1 - 0.09) * 0.05,
                {"inner_rim": 2 * math.pi * 0.3 * 0.05, "x3_min": math.pi * (1 - 0.09)},
                ([-1, -1, -0.025], [1, 1, 0.025])),
    "cylinder_shell": ({"radius": R, "height": 0.4, "thickness": T}, 0.1,
                       math.pi * (R**2 - (R - T) ** 2) * 0.4,
                       {"bottom_rim": math.pi * (R**2 - (R - T) ** 2),
                        "outer": 2 * math.pi * R * 0.4}, ([-R, -R, 0], [R, R, 0.4])),
    "cube": ({"side": 2.0}, 0.5, 8.0, {"x2_min": 4.0}, ([-1, -1, -1], [1, 1, 1])),
    "rectangle": ({"side": 4.0}, 0.5, 16.0, {"x1_max": 4.0}, ([-2, -2, 0], [2, 2, 0])),
}


def config(kind, params, size, cache_dir, layers=2, clamp="rigid", **mesh):
    dim = 2 if kind == "rectangle" else 3
    return from_dict({"name": kind, "geometry": {"kind": kind, **params},
                      "mesh": {"size": size, "layers": layers, "cache_dir": str(cache_dir), **mesh},
                      "model": {"dim": dim, "degree": 1}, "boundary": {"clamp": clamp}})


@pytest.mark.mpi
@pytest.mark.parametrize("kind", list(CASES))
def test_geometry_volume_boundaries_and_placement(kind, shared_tmp):
    params, size, volume, areas, (lo, hi) = CASES[kind]
    cfg = config(kind, params, size, shared_tmp)
    domain = load_domain(cfg, MPI.COMM_WORLD)
    mesh = domain.mesh
    comm = mesh.comm

    def integrate(form):
        return comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(form)), MPI.SUM)

    one = dolfinx.fem.Constant(mesh, 1.0)
    curved = kind in ("tube", "annulus", "cylinder_shell")  # polygonal circles
    rel = 0.02 if curved else 1e-12
    exact = {"quadrature_degree": 6}  # a second order hexahedron's det J (UFL's guess: 125 points)
    assert integrate(one * ufl.dx(domain=mesh, metadata=exact)) == pytest.approx(volume, rel=rel)
    total = 0.0
    for name in BOUNDARIES[kind]:
        area = integrate(one * domain.ds(name, exact))
        assert area > 0, f"{name} has no facets"
        if name in areas:
            assert area == pytest.approx(areas[name], rel=rel), name
        total += area
    every = integrate(one * ufl.ds(domain=mesh, metadata=exact))
    assert total == pytest.approx(every, rel=1e-12)  # every facet named once
    box_lo, box_hi = body_box(mesh)
    sagitta = size**2 / 2 if curved else 1e-9  # a chord of length h misses a unit circle by ~h^2/8
    assert box_lo == pytest.approx(lo, abs=sagitta)
    assert box_hi == pytest.approx(hi, abs=sagitta)


@pytest.mark.mpi
def test_layers_through_the_wall(shared_tmp):
    """The box's thickness is split into exactly `layers` elements: vertices on 3 planes (and
    a second order mesh's mid-nodes between them: 5 on hexahedra)."""
    cfg = config("box", {"length": 0.4, "width": 0.1, "thickness": 0.02}, 0.05, shared_tmp,
                 layers=2)
    mesh = load_domain(cfg).mesh
    z = np.unique(np.round(mesh.geometry.x[:, 2], 12))
    planes = np.unique(np.concatenate(mesh.comm.allgather(z)))
    assert planes == pytest.approx(np.linspace(-0.01, 0.01, 2 * compat.geometry_degree(mesh) + 1))


RINGS = {  # kind: (parameters, the clamped face's axis)
    "tube": ({"length": 0.5, "radius": 1.0, "thickness": 0.05}, 0),
    "cylinder_shell": ({"radius": 1.0, "height": 0.5, "thickness": 0.05}, 2),
}


@pytest.mark.mpi
@pytest.mark.parametrize("kind", sorted(RINGS))
@pytest.mark.parametrize(("size", "layers"), [(1.0, 1), (0.5, 1), (0.5, 2), (0.25, 3)])
def test_a_walls_ring_follows_mesh_size_and_layers(kind, size, layers, shared_tmp):
    """The tube's and the shell's ring: 4 ceil(round(2 pi R / h) / 4) segments round (at least
    8) and ``layers`` elements through the wall, on the face at the start of the sweep.  (The
    ring's counts were once lost to a synchronize: 8 round and 1 layer at every size.)"""
    params, axis = RINGS[kind]
    mesh = load_domain(config(kind, params, size, shared_tmp, layers=layers)).mesh
    x = mesh.geometry.x
    face = np.concatenate(mesh.comm.allgather(np.round(x[np.abs(x[:, axis]) < 1e-9], 9)))
    face = np.unique(face, axis=0)
    radii = np.unique(np.round(np.linalg.norm(np.delete(face, axis, axis=1), axis=1), 6))
    around = 4 * math.ceil(max(8, round(2 * math.pi / size)) / 4)
    order = compat.geometry_degree(mesh)  # a second order mesh's mid-nodes: between the vertices
    assert radii == pytest.approx(np.linspace(0.95, 1.0, order * layers + 1))
    assert len(face) == order * around * (order * layers + 1)


def test_cache_is_keyed_by_parameters(tmp_path):
    a = config("cube", {"side": 1.0}, 0.5, tmp_path)
    b = config("cube", {"side": 1.0}, 0.25, tmp_path)
    assert mesh_path(a) != mesh_path(b)
    assert mesh_path(a) == mesh_path(config("cube", {"side": 1.0}, 0.5, tmp_path))
    load_domain(a, MPI.COMM_SELF)
    stamp = mesh_path(a).stat().st_mtime_ns
    load_domain(a, MPI.COMM_SELF)
    assert mesh_path(a).stat().st_mtime_ns == stamp  # reused, not rebuilt


@pytest.mark.parametrize("squash", [0.0, 1e-10])
def test_a_mesh_with_a_flat_cell_is_refused_with_one_clear_line(squash):
    """Two tetrahedra on a shared face; the apex of the second pushed into that face."""

    from shapegrowth.config import ConfigError
    from shapegrowth.physics.geometry import check_cells

    x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.3, 0.3, squash]], float)
    cells = np.array([[0, 1, 2, 3], [0, 1, 2, 4]], np.int64)
    if MPI.COMM_WORLD.rank:
        x, cells = np.zeros((0, 3)), np.zeros((0, 4), np.int64)
    mesh = compat.create_mesh(MPI.COMM_WORLD, cells, x, "tetrahedron")
    with pytest.raises(ConfigError, match=r"mesh.size: 1 of 2 cells are flat, collapsed or inverted"):
        check_cells(mesh)


def _cell_x1_extent(mesh) -> tuple[np.ndarray, np.ndarray]:
    """(lowest X1, X1 extent) of every owned cell."""
    n = mesh.topology.index_map(mesh.topology.dim).size_local
    x = mesh.geometry.x[compat.geometry_nodes(mesh)[:n], 0]
    return x.min(axis=1), x.max(axis=1) - x.min(axis=1)


@pytest.mark.mpi
def test_box_graded_towards_its_clamp(shared_tmp):
    """mesh.clamp_size: cells at X1 = 0 of that size, the far end of the uniform size."""
    params = {"length": 1.0, "width": 0.1, "thickness": 0.02}
    graded = config("box", params, 0.1, shared_tmp, clamp="x1_min", clamp_size=0.01)
    mesh = load_domain(graded).mesh
    lo, extent = _cell_x1_extent(mesh)
    comm = mesh.comm
    at_clamp = comm.allreduce(extent[lo < 1e-12].max(initial=0.0), MPI.MAX)
    far = comm.allreduce(extent[lo > 0.6].max(initial=0.0), MPI.MAX)
    assert at_clamp < 1.5 * 0.01
    assert far > 0.5 * 0.1
    volume = comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(
        dolfinx.fem.Constant(mesh, 1.0) * ufl.dx)), MPI.SUM)
    assert volume == pytest.approx(1.0 * 0.1 * 0.02, rel=1e-12)


GRADED_BODIES = {  # kind: (parameters, clamp, mesh size, clamp size, distance from the clamp)
    "tube": ({"length": 1.0, "radius": 0.2, "thickness": 0.05}, "x1_min", 0.1, 0.02,
             lambda x: x[:, 0]),
    "annulus": ({"radius": 1.0, "inner_radius": 0.2, "thickness": 0.05}, "inner_rim", 0.3,
                0.05, lambda x: np.hypot(x[:, 0], x[:, 1]) - 0.2),
    "cylinder_shell": ({"radius": 1.0, "height": 0.7, "thickness": 0.05}, "bottom_rim", 0.2,
                       0.04, lambda x: x[:, 2]),
}


@pytest.mark.mpi
@pytest.mark.parametrize("kind", sorted(GRADED_BODIES))
def test_every_clamped_body_grades_towards_its_clamp(kind, shared_tmp):
    """mesh.clamp_size on the tube, the annulus and the cylinder shell: the cells at the
    clamp far smaller than those away from it, the body's volume unchanged."""
    params, clamp, size, h_min, distance = GRADED_BODIES[kind]
    meshes = [load_domain(config(kind, params, size, shared_tmp, clamp=clamp, **extra)).mesh
              for extra in ({}, {"clamp_size": h_min})]
    comm = meshes[0].comm
    near, far, volumes = [], [], []
    for mesh in meshes:
        n = mesh.topology.index_map(3).size_local
        x = mesh.geometry.x[compat.geometry_nodes(mesh)[:n]]
        d = distance(x.reshape(-1, 3)).reshape(-1, 4)
        edge = d.max(axis=1) - d.min(axis=1)  # each cell's extent away from the clamp
        touching = np.abs(d).min(axis=1) < 1e-9  # a vertex on the clamp
        # the mean extent of the cells at the clamp, the largest far from it
        at = comm.allreduce(np.array([edge[touching].sum(), touching.sum()]), MPI.SUM)
        near.append(at[0] / at[1])
        far.append(comm.allreduce(edge[d.min(axis=1) > 0.5].max(initial=0.0), MPI.MAX))
        volumes.append(comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(
            dolfinx.fem.Constant(mesh, 1.0) * ufl.dx)), MPI.SUM))
    assert near[1] < 0.5 * near[0]  # graded: smaller cells at the clamp
    assert far[1] > 0.5 * far[0]  # and the uniform size away from it
    assert volumes[1] == pytest.approx(volumes[0], rel=1e-2)  # polygonal rims: finer is truer


@pytest.mark.mpi
def test_refined_mesh_is_nested_and_carries_p1_fields_exactly(shared_tmp):
    """mesh.refine: 8x the cells, the coarse vertices kept, a coarse P1 field exact on it."""
    from shapegrowth.physics.transfer import interpolate_between_meshes

    params = {"length": 1.0, "width": 0.2, "thickness": 0.1}
    coarse = config("box", params, 0.2, shared_tmp)
    fine = config("box", params, 0.2, shared_tmp, refine=1)
    domains = [load_domain(c) for c in (coarse, fine)]
    meshes = [d.mesh for d in domains]
    comm = meshes[0].comm
    cells = [comm.allreduce(m.topology.index_map(3).size_local, MPI.SUM) for m in meshes]
    assert cells[1] == 8 * cells[0]
    fields = [dolfinx.fem.Function(compat.scalar_space(m, 1)) for m in meshes]
    fields[0].interpolate(lambda p: np.sin(7 * p[0]) * np.cos(5 * p[1]) + 3 * p[2])
    interpolate_between_meshes(fields[0], fields[1])
    exact = {"quadrature_degree": 4}  # f^2 exactly (UFL's guess on hexahedra: 125 points)
    squares = [comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(
        f * f * ufl.dx(domain=f.function_space.mesh, metadata=exact))), MPI.SUM) for f in fields]
    assert squares[1] == pytest.approx(squares[0], rel=1e-12)  # the same piecewise-linear field
    assert squares[1] > 1e-3
    # the refined facets keep their boundary names
    fine_domain = domains[1]
    area = comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(
        dolfinx.fem.Constant(meshes[1], 1.0) * fine_domain.ds("x1_min", exact))), MPI.SUM)
    assert area == pytest.approx(0.2 * 0.1, rel=1e-12)


@pytest.mark.mpi
def test_two_builds_partition_the_mesh_alike(shared_tmp):
    """The same mesh file read twice gives every rank the same cells in the same order
    (the default PT-SCOTCH partition changed between builds), so runs repeat and a
    checkpoint's design fits a new build."""
    cfg = config("box", {"length": 1.0, "width": 0.1, "thickness": 0.02}, 0.05, shared_tmp,
                 layers=2)
    first, second = load_domain(cfg).mesh, load_domain(cfg).mesh
    n = first.topology.index_map(3).size_local
    assert n == second.topology.index_map(3).size_local
    assert n > 0
    assert np.array_equal(first.geometry.x, second.geometry.x)
    sizes = MPI.COMM_WORLD.allgather(n)
    assert max(sizes) - min(sizes) <= 1  # equal blocks of the cell order


@pytest.mark.mpi
def test_a_mesh_that_fails_to_build_fails_on_every_rank(shared_tmp, monkeypatch):
    """Rank 0 builds; where gmsh fails there, every rank raises the error instead of waiting
    for a mesh that never comes (a run on 2 ranks hung so)."""
    from shapegrowth.physics import geometry

    def failing(cfg, path):
        raise ValueError("no mesh today")

    monkeypatch.setattr(geometry, "build", failing)
    monkeypatch.setattr(geometry, "build_hex", failing)
    cfg = config("cube", {"side": 1.0}, 0.3, shared_tmp)
    with pytest.raises(RuntimeError, match="no mesh today"):
        geometry.ensure_mesh(cfg)


@pytest.mark.mpi
@pytest.mark.skipif(compat.AT_LEAST_0_9, reason="only dolfinx 0.5.2's XDMF writer pulls the "
                    "geometry's nodes back into their cells")
def test_a_curved_mesh_the_xdmf_writer_cannot_pull_back_is_refused_on_every_rank(shared_tmp):
    """dolfinx 0.5.2's writer evaluates each field at every node of the geometry in a cell of
    its own rank, and a rank whose cell cannot be pulled back raised alone while the others
    entered the file's collective write (a hang: the sample hammer on two ranks).  Here only
    rank 0 holds such a node (at NaN): every rank raises, before any file is made."""
    from shapegrowth.physics.mid_surfaces import annulus_surface

    mesh = annulus_surface(MPI.COMM_WORLD, 0.2, 1.0, 16, 4).mesh
    f = dolfinx.fem.Function(compat.scalar_space(mesh, 2))
    path = shared_tmp / "fields.xdmf"
    compat.write_xdmf(path, mesh, [f])  # a sound curved mesh is written
    assert path.is_file()
    mesh.comm.barrier()
    if mesh.comm.rank == 0:
        path.unlink()
        mesh.geometry.x[0, :] = np.nan
    with pytest.raises(RuntimeError, match="non-affine geometry"):
        compat.write_xdmf(path, mesh, [f])
    mesh.comm.barrier()
    assert not path.exists()
