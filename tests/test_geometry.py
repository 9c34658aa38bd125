"""gmsh geometries: placement, named boundaries and volumes, serial and distributed."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

import dolfinx.fem
import ufl
from shapegrowth.boundary import body_box
from shapegrowth.config import BOUNDARIES, from_dict
from shapegrowth.geometry import load_domain, mesh_path

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


def config(kind, params, size, cache_dir, layers=2):
    dim = 2 if kind == "rectangle" else 3
    return from_dict({"name": kind, "geometry": {"kind": kind, **params},
                      "mesh": {"size": size, "layers": layers, "cache_dir": str(cache_dir)},
                      "model": {"dim": dim, "degree": 1}, "boundary": {"clamp": "rigid"}})


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
    assert integrate(one * ufl.dx) == pytest.approx(volume, rel=rel)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=domain.facet_tags)
    total = 0.0
    for name in BOUNDARIES[kind]:
        area = integrate(one * ds(domain.boundaries[name]))
        assert area > 0, f"{name} has no facets"
        if name in areas:
            assert area == pytest.approx(areas[name], rel=rel), name
        total += area
    assert total == pytest.approx(integrate(one * ufl.ds), rel=1e-12)  # every facet named once
    box_lo, box_hi = body_box(mesh)
    sagitta = size**2 / 2 if curved else 1e-9  # a chord of length h misses a unit circle by ~h^2/8
    assert box_lo == pytest.approx(lo, abs=sagitta)
    assert box_hi == pytest.approx(hi, abs=sagitta)


@pytest.mark.mpi
def test_layers_through_the_wall(shared_tmp):
    """The box's thickness is split into exactly `layers` elements: vertices on 3 planes."""
    cfg = config("box", {"length": 0.4, "width": 0.1, "thickness": 0.02}, 0.05, shared_tmp,
                 layers=2)
    mesh = load_domain(cfg).mesh
    z = np.unique(np.round(mesh.geometry.x[:, 2], 12))
    planes = np.unique(np.concatenate(mesh.comm.allgather(z)))
    assert planes == pytest.approx([-0.01, 0.0, 0.01])


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
    import dolfinx.mesh

    from shapegrowth.config import ConfigError
    from shapegrowth.geometry import check_cells

    x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.3, 0.3, squash]], float)
    cells = np.array([[0, 1, 2, 3], [0, 1, 2, 4]], np.int64)
    if MPI.COMM_WORLD.rank:
        x, cells = np.zeros((0, 3)), np.zeros((0, 4), np.int64)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", "tetrahedron", 1))
    mesh = dolfinx.mesh.create_mesh(MPI.COMM_WORLD, cells, x, domain)
    with pytest.raises(ConfigError, match=r"mesh.size: 1 of 2 cells are flat or collapsed"):
        check_cells(mesh)
