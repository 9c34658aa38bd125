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
# # 01 Growth basics: bend, twist, cup
#
# A growth tensor $C_g = \sum_i \lambda_i\, v_i \otimes v_i$ tells each material point how
# it would like to grow; the body then finds the elastic equilibrium closest to that
# wish (the Mooney-Rivlin energy (5.1) of the paper, with $C_g$ in it). Here we set
# growth fields by hand, with no optimisation, and look at three classic shapes:
#
# * a beam **bends** when its top fibres grow more than its bottom ones,
# * a strip **twists** when the direction of growth turns through its thickness,
# * a disk **cups** when its upper face grows more than its lower one, in every in-plane
#   direction.
#
# Everything runs on tiny meshes in seconds; the same script runs under
# `mpirun -n 2 python notebooks/01_growth_basics.py`.

# %%
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

from shapegrowth import ForwardModel, build_model, draw, evaluate_at, load_config, surface

CONFIGS = Path.cwd().parent / "configs" if Path.cwd().name == "notebooks" else Path("configs")
rank0 = MPI.COMM_WORLD.rank == 0


def solved(config: Path, *overrides: str) -> ForwardModel:
    """The forward model of a config, with its initial growth applied and in equilibrium."""
    model = build_model(load_config(config, list(overrides)))
    report = model.state.solve()
    assert report.converged, report.reason
    if rank0:
        print(f"{config.name}: {report.steps} load steps, "
              f"{report.newton_iterations} Newton iterations")
    return model


def show(surf, title: str, elev: float, azim: float, label: str | None = None) -> None:
    """The deformed surface in 3D (on rank 0), coloured by its field when it has one."""
    if not rank0:
        return
    fig = plt.figure(figsize=(6, 4))
    ax = fig.add_subplot(projection="3d")
    poly = draw(ax, surf)
    if label:
        fig.colorbar(poly, ax=ax, shrink=0.6, label=label)
    ax.view_init(elev=elev, azim=azim)
    ax.set_title(title)
    plt.show()


# %% [markdown]
# ## Bend
# With $\lambda_1 = (1 + \kappa X_3)^2$ along the beam axis the fibres at height $X_3$ are
# stretched by $1 + \kappa X_3$: the beam bends (away from the side that grows more) into
# an arc of curvature $\kappa$. At $\kappa L = \pi$ the tip of a beam of length 1 lands at
# $(0, 0, -2/\pi) \approx (0, 0, -0.637)$; this tiny mesh gets within about 1 %.

# %%
beam = solved(CONFIGS / "tiny" / "beam_bend.yaml", f"parameters.kappa={np.pi}")
tip = evaluate_at(beam.state.u, np.array([[1.0, 0.0, 0.0]]))[0] + [1, 0, 0]
if rank0:
    print("tip at", np.round(tip, 4), "(closed form: 0, 0, -0.6366)")

# %%
show(surface(beam.state.u, beam.growth.eigenvalues[0]), "bend: top fibres grow more",
     elev=5, azim=-90, label=r"$\hat\lambda_1$")

# %% [markdown]
# ## Twist
# Now the growth is along one direction $v_1$ only ($\lambda_1 = 1.15$), and $v_1$ turns
# through the thickness: from $-45^\circ$ at the bottom face to $+45^\circ$ at the top
# (a free frame with the Rodrigues angle $\theta_3$ about $X_3$). Each layer wants to grow
# along a different diagonal, and the strip twists into a helicoid.

# %%
strip = solved(CONFIGS / "tiny" / "beam_bend.yaml",
               "growth.frame=free",
               "growth.eigenvalues.initial=[1.15, 1.0, 1.0]",
               # pi -/+ pi/4: the same lines as -/+45 degrees
               "growth.angles.initial=[0, 0, 'pi + pi/2*x3/thickness']",
               "geometry.width=0.3", "mesh.layers=2")
show(surface(strip.state.u), "twist: the growth direction turns through the thickness",
     elev=20, azim=-60)

# %% [markdown]
# ## Cup
# An annulus clamped at its inner rim, with isotropic in-plane growth
# $\lambda_1 = \lambda_2 = (1 + \kappa X_3)^2$ in the cylindrical frame: the upper face
# grows more than the lower one in every direction, and the disk curls into a cup
# (positive Gaussian curvature). A flat disk cannot take a sphere's shape without
# stretching its mid-surface, so a thin one also waves at the rim as the growth increases.

# %%
disk = solved(CONFIGS / "disk_cone.yaml",  # its body; this growth given by hand
              "mesh.size=0.2", "mesh.layers=1", "growth.start=given", "solver.branch=follow",
              "solver.max_newton_iterations=15",
              "growth.eigenvalues.initial=['(1 + x3)**2', '(1 + x3)**2', 1.0]")
cup = surface(disk.state.u)
show(cup, "cup: the upper face grows more in every direction", elev=15, azim=-60)
if rank0:
    z = cup.deformed[:, 2]
    print(f"rim lifted by {z.max() - z.min():.3f} (disk radius 1)")
