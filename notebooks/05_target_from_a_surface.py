# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 05 Program a beam into a shape read from an STL file
#
# A soft-robotics target usually comes as a surface: an STL from CAD or a scan, in
# millimetres, placed wherever its author worked. `target: {surface: shape.stl}` reads it
# (STL, OBJ, PLY or gmsh .msh triangles), fills the closed surface with tetrahedra (gmsh),
# and `target.transform` puts it where the body is: `scale`, `rotation` (degrees about X1,
# then X2, then X3), `translation`, or `align: principal_axes` (centroid and axes of
# inertia onto the body's).
#
# To know the answer, the STL here is made by a known growth: the beam of
# `configs/reachable/bend.yaml` grown by $\lambda_1 = (1 + \kappa X_3)^2$ rolls into a
# quarter circle; its deformed boundary is written as an STL **in millimetres, turned by 90
# degrees about X3 and moved by (500, 200, 0) mm**, as a CAD export would be. The optimiser
# then starts from no growth and has only the file.

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

from shapegrowth import (
    build_model,
    draw,
    evaluate_at,
    load_config,
    optimize,
    read_surface,
    surface,
    write_stl,
)

CONFIGS = Path.cwd().parent / "configs" if Path.cwd().name == "notebooks" else Path("configs")
OUT = Path("results/notebook_surface_target")
BEND = CONFIGS / "reachable" / "bend.yaml"
COARSE = ["mesh.size=0.1", "mesh.layers=1"]
comm = MPI.COMM_WORLD
rank0 = comm.rank == 0

# %% [markdown]
# ## The "CAD" file: a grown beam, exported in millimetres somewhere else

# %%
KNOWN = "growth.eigenvalues.initial=['(1 + kappa*x3)**2', 1, 1]"  # the compatible bend
known = build_model(load_config(BEND, [KNOWN]))  # on the config's own, finer mesh
assert known.state.solve().converged
grown = surface(known.state.u)  # the deformed boundary triangles, on every rank
turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 degrees about X3
placed = 1000 * grown.deformed @ turn.T + np.array([500.0, 200.0, 0.0])
stl = OUT / "bent_beam_mm.stl"
if rank0:
    write_stl(stl, placed, grown.triangles)
comm.barrier()
shape = read_surface(stl)
if rank0:
    lo, hi = shape.points.min(axis=0), shape.points.max(axis=0)
    print(f"{stl.name}: {len(shape.triangles)} triangles, box {np.round(lo)} .. "
          f"{np.round(hi)} mm")

# %% [markdown]
# ## The config: the file and its placement
# The file's x' = R (1000 x) + t0 is undone by scale 0.001, rotation -90 degrees about X3
# and the translation -R^T t0 / 1000 = (-0.2, 0.5, 0). In YAML:
#
# ```yaml
# target:
#   surface: bent_beam_mm.stl
#   transform: {scale: 0.001, rotation: [0, 0, -90], translation: [-0.2, 0.5, 0]}
# ```

# %%
cfg = load_config(BEND, COARSE + [
    "target.map=null", f"target.surface={stl}", "target.transform.scale=0.001",
    "target.transform.rotation=[0, 0, -90]", "target.transform.translation=[-0.2, 0.5, 0]",
    "optimizer.max_iterations=40"])
result = optimize(cfg, OUT / "run")
s = result.summary
if rank0:
    print(f"{s.status} after {s.iterations} iterations in {s.wall_time_s:.0f} s")
    print(f"verified shape error {100 * s.verified.relative:.2f} % of the target size (the "
          "best growth grown from rest on the mesh refined once, against the STL's solid)")
    print(f"self-reported {100 * s.relative_error:.2f} % (on this mesh, along the "
          "optimiser's path)")

# %% [markdown]
# ## The programmed growth against the growth that made the file
# The optimiser never saw $\lambda_1 = (1 + \kappa X_3)^2$. The shape fixes the
# difference of growth between top and bottom fibres (the curvature), not each value: the
# design also moves $\lambda_2, \lambda_3$, so the growth found need not be the one that
# made the file. Along the beam's mid-line the top and bottom fibres:

# %%
model = result.model
lam1 = model.state.applied.eigenvalues[0]
kappa = np.pi / 2  # the config's parameter
x1 = np.linspace(0.05, 0.95, 7)
top = np.column_stack([x1, 0 * x1, 0 * x1 + 0.01])
bottom = np.column_stack([x1, 0 * x1, 0 * x1 - 0.01])
found_top, found_bottom = evaluate_at(lam1, top)[:, 0], evaluate_at(lam1, bottom)[:, 0]
if rank0:
    print("X1      lambda_1 top (found / known)   bottom (found / known)")
    for x, a, b in zip(x1, found_top, found_bottom):
        print(f"{x:.2f}   {a:.3f} / {(1 + kappa * 0.01) ** 2:.3f}"
              f"                {b:.3f} / {(1 - kappa * 0.01) ** 2:.3f}")

# %% [markdown]
# ## The grown beam over the file's solid (side view)

# %%
beam = surface(model.state.u, lam1)
back = (shape.points - np.array([500.0, 200.0, 0.0])) @ turn / 1000  # the file, placed
if rank0:
    fig, ax = plt.subplots(figsize=(6, 4))
    artist = draw(ax, beam, plane=(0, 2), edgecolor="0.85")
    ax.plot(back[:, 0], back[:, 2], ".", ms=1.5, color="k", alpha=0.3, label="STL vertices")
    fig.colorbar(artist, ax=ax, label=r"$\hat\lambda_1$")
    ax.set_xlabel("$x_1$")
    ax.set_ylabel("$x_3$")
    ax.set_aspect("equal")
    ax.legend(loc="lower left")
    plt.show()
