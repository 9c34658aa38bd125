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
# # 06 Program a plate onto a scanned relief, and make it of two materials
#
# A 4D-printing target is often an open surface: a scan of a relief, in millimetres, with a
# free edge and the scanner's noise. What must match it is one face of the plate, its top;
# `objective.compare: top` compares that face (its areas pushed forward exactly) with the
# surface (its area measure), and the exact Hausdorff distance is measured surface to
# surface.
#
# The plate is free: `boundary.clamp: rigid` only pins three vertices, and the mesh chooses
# them. `objective.placement: fitted` compares the deformed top in its least-squares
# placement over the flat one, so the shape, not the pins, decides.
#
# To know the answer, the "scan" is a relief the plate can take exactly: a corrugation whose
# curvature along X1 is $\kappa(s) = A \sin 2\pi s$ at arc length $s$ (a developable
# surface, reached stress-free by $\lambda_1 = (1 + \kappa(X_1) X_3)^2$). It is written
# with numpy on a 161 x 41 grid of its own, in millimetres, with 0.05 mm of noise. The
# optimiser starts from no growth and has only the file. At the end the same plate is
# designed of two materials and written as one STL file per material.

# %%
import json
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

from shapegrowth import (
    Objective,
    RigidFit,
    draw,
    evaluate_at,
    load_config,
    optimize,
    read_surface,
    surface,
    write_stl,
)

OUT = Path("results/notebook_relief")
comm = MPI.COMM_WORLD
rank0 = comm.rank == 0
A, T = 3.0, 0.02  # the corrugation's curvature amplitude; the plate's thickness

# %% [markdown]
# ## The scan: a corrugated relief in millimetres
# The plate's mid-line follows the angle $\theta(s) = -\int_0^s \kappa$; its top face lies
# $T/2$ off it along the normal. The relief is then placed as the fit places the plate's top
# face: its least-squares rotation and centroid over the flat face (`RigidFit`, the fit of
# `objective.placement: fitted`).

# %%
s = np.linspace(0.0, 1.0, 161)
y = np.linspace(-0.5, 0.5, 41)
theta = -A * (1 - np.cos(2 * np.pi * s)) / (2 * np.pi)


def integral(f):
    return np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(s))])


top = np.column_stack([integral(np.cos(theta)), integral(np.sin(theta))])
top += T / 2 * np.column_stack([-np.sin(theta), np.cos(theta)])  # (x1, x3) along s
i, j = np.meshgrid(np.arange(len(s)), np.arange(len(y)), indexing="ij")
points = np.column_stack([top[i.ravel(), 0], y[j.ravel()], top[i.ravel(), 1]])
flat = np.column_stack([s[i.ravel()], y[j.ravel()], np.full(i.size, T / 2)])
points = RigidFit(flat, np.ones(len(flat)), MPI.COMM_SELF)(points)
corner = (len(y) * i[:-1, :-1] + j[:-1, :-1]).ravel()
triangles = np.concatenate([np.column_stack([corner, corner + len(y), corner + len(y) + 1]),
                            np.column_stack([corner, corner + len(y) + 1, corner + 1])])
scan = 1000 * points + np.random.default_rng(0).normal(0.0, 0.05, points.shape)  # mm
stl = OUT / "relief_mm.stl"
if rank0:
    write_stl(stl, scan, triangles)
comm.barrier()
relief = read_surface(stl)
if rank0:
    lo, hi = relief.points.min(axis=0), relief.points.max(axis=0)
    print(f"{stl.name}: {len(relief.triangles)} triangles, an open surface, box "
          f"{np.round(lo)} .. {np.round(hi)} mm")

# %% [markdown]
# ## The config
# A plate of 1 x 1 x 0.02 on a coarse mesh, everything else at its defaults (L-BFGS, alpha
# 100, the debiased objective, the verification on the mesh refined once, grown from rest).

# %%
config = OUT / "plate.yaml"
if rank0:
    config.write_text(
        "name: plate_relief\n"
        "geometry: {kind: box, length: 1.0, width: 1.0, thickness: 0.02}\n"
        "mesh: {size: 0.1, layers: 1}\n"
        "model: {dim: 3, degree: 2}\n"
        "boundary: {clamp: rigid}\n"
        "target:\n"
        f"  surface: {stl}\n"  # a path relative to where the run starts
        "  transform: {scale: 0.001}\n"
        "objective: {compare: top, placement: fitted}\n"
        "optimizer: {max_iterations: 30}\n")

comm.barrier()
cfg = load_config(config)
result = optimize(cfg, OUT / "run")
s_ = result.summary
first = s_.hausdorff_initial / s_.target_size
# what this notebook shows, checked wherever it runs (`make notebooks`, serially and on two
# ranks): within the 30 iterations the exact distance, on this mesh and verified, halves
assert s_.hausdorff_final / s_.target_size < first / 2 and s_.verified.relative < first / 2
if rank0:
    print(f"{s_.status} after {s_.iterations} iterations in {s_.wall_time_s:.0f} s")
    print(f"verified shape error {100 * s_.verified.relative:.2f} % of the relief's size (the "
          "best growth grown from rest on the mesh refined once, surface to surface)")
    print(f"self-reported {100 * s_.relative_error:.2f} % (this mesh, the optimiser's path); "
          f"{100 * first:.2f} % at the start, flat")

# %% [markdown]
# ## The plate over the scan
# The deformed plate, placed as it was compared, coloured by $\hat\lambda_1$, with every
# third of the scan's vertices (black); $x_3$ drawn three times stretched.

# %%
model = result.model
lam1 = model.state.applied.eigenvalues[0]
place, _ = Objective(cfg, model.state).placements()
plate = surface(model.state.u, lam1)
plate_points = place(plate.deformed)
if rank0:
    from shapegrowth.io.plotting import Surface

    fig = plt.figure(figsize=(8, 5))
    ax = fig.add_subplot(projection="3d", computed_zorder=False)
    artist = draw(ax, Surface(plate.reference, plate_points, plate.triangles, plate.values),
                  linewidth=0.1)
    dots = relief.points[::3] / 1000
    ax.scatter(dots[:, 0], dots[:, 1], dots[:, 2], s=0.6, c="k", alpha=0.6, depthshade=False,
               zorder=3)
    lo, hi = plate_points.min(axis=0), plate_points.max(axis=0)
    for set_lim, a, b in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), lo, hi):
        set_lim(a, b)
    ax.set_box_aspect((hi - lo) * np.array([1.0, 1.0, 3.0]))
    ax.view_init(elev=25, azim=-65)
    ax.set_xlabel("$x_1$")
    ax.set_ylabel("$x_2$")
    ax.set_zlabel("$x_3$")
    fig.colorbar(artist, ax=ax, label=r"$\hat\lambda_1$", shrink=0.5)
    plt.show()

# %% [markdown]
# ## The growth found against the growth that made the scan
# The shape fixes the difference of growth between top and bottom fibres (the curvature):
# along the mid-line, $\hat\lambda_1$ on the top and bottom faces against
# $(1 \pm \kappa T/2)^2$.

# %%
x1 = np.linspace(0.1, 0.9, 5)
found_top = evaluate_at(lam1, np.column_stack([x1, 0 * x1, 0 * x1 + T / 2]))[:, 0]
found_bottom = evaluate_at(lam1, np.column_stack([x1, 0 * x1, 0 * x1 - T / 2]))[:, 0]
kappa = A * np.sin(2 * np.pi * x1)
if rank0:
    print("X1     top found / known     bottom found / known")
    for x, a, b, k in zip(x1, found_top, found_bottom, kappa):
        print(f"{x:.2f}   {a:.3f} / {(1 + k * T / 2) ** 2:.3f}         "
              f"{b:.3f} / {(1 - k * T / 2) ** 2:.3f}")

# %% [markdown]
# ## Two materials a printer can make
# A printed plate is made of a few materials, each of one growth (swelling) ratio. The
# growth that made the scan is a difference between the top and bottom fibres along $X_1$
# (0.94-1.06), so $\lambda_1$ alone is designed, with `growth.levels: [0.94, 1.06]`: it ends
# at one of the two everywhere, in regions no smaller than the filter length (20 mm), and
# `growth.grey_penalty` keeps the design from resting between the levels, where the crisp
# rounding would move it. The run ends with that crisp design, grown from rest and verified
# as before; `fabrication/` holds one closed STL per material and `fabrication.json`.

# %%
two = OUT / "plate_two_materials.yaml"
if rank0:
    two.write_text(config.read_text().replace("max_iterations: 30", "max_iterations: 60")
                   + "growth: {eigenvalues: {design: [1]}, levels: [0.94, 1.06], "
                     "sharpness: [1, 4, 16],\n         filter_length: 0.02, grey_penalty: 0.01}\n")
comm.barrier()
crisp = optimize(load_config(two), OUT / "two")
c_ = crisp.summary
made = json.loads((OUT / "two" / c_.fabrication).read_text())
if rank0:
    print(f"two materials: {c_.status}, verified {made['verified_status']}: "
          f"{100 * (made['verified'] or float('nan')):.2f} % against the continuous design's "
          f"{100 * s_.verified.relative:.2f} %; {100 * made['grey_fraction']:.0f} % of the "
          "volume grey at the last sharpness")
    for m in made["materials"]:
        print(f"material {m['index']}: growth {m['growth']}, {100 * m['volume_fraction']:.1f} % "
              f"of the volume in {m['pieces']} piece(s), smallest feature "
              f"{1000 * m['smallest_feature']:.1f} mm, {m['stl']}")

# %% [markdown]
# The materials' STL files as a printer reads them (the reference plate, before growth;
# $x_3$ drawn ten times stretched).

# %%
if rank0:
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = plt.figure(figsize=(8, 4))
    ax = fig.add_subplot(projection="3d")
    for m, colour in zip(made["materials"], ("tab:blue", "tab:orange", "tab:green",
                                             "tab:red", "tab:purple", "tab:brown")):
        part = read_surface(OUT / "two" / "fabrication" / m["stl"])
        ax.add_collection3d(Poly3DCollection(part.points[part.triangles], facecolor=colour,
                                             edgecolor="none", alpha=0.8))
    ax.set_xlim(0, 1)
    ax.set_ylim(-0.5, 0.5)
    ax.set_zlim(-T, T)
    ax.set_box_aspect((1.0, 1.0, 20 * T))
    ax.set_xlabel("$X_1$")
    ax.set_ylabel("$X_2$")
    plt.show()
