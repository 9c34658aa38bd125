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
# # 04 Speed against accuracy
#
# A coarse model is cheap but may lie about itself: P1 tetrahedra lock in bending, and a
# mesh that is too coarse can match the target with a growth that a finer model would
# not follow. `shapegrowth study` therefore judges every optimum on a **reference**
# discretisation (by default the finest one of the sweep): the optimal growth is
# interpolated onto it, the state is solved there, and the exact Hausdorff distance to
# the target is measured. Here, a small grid on the beam of scene 1:
# mesh size $\times$ displacement degree, 25 L-BFGS iterations each.
#
# The same from the shell:
# `shapegrowth study configs/beam_wave.yaml --sweep mesh.size=0.2,0.1 --sweep model.degree=1,2`.

# %%
import csv
import shutil
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

from shapegrowth import Sweep, pareto_front, run_study

CONFIGS = Path.cwd().parent / "configs" if Path.cwd().name == "notebooks" else Path("configs")
OUT = Path("results/notebook_study")
rank0 = MPI.COMM_WORLD.rank == 0

if rank0:  # a study resumes from what it finds: start afresh
    shutil.rmtree(OUT, ignore_errors=True)
MPI.COMM_WORLD.barrier()
sweeps = [Sweep.parse("mesh.size=0.2,0.1"), Sweep.parse("model.degree=1,2")]
rows = run_study(CONFIGS / "beam_wave.yaml",
                 ["mesh.layers=1", "optimizer.max_iterations=25",  # one model per point:
                  "optimizer.levels=[0]", "optimizer.level_iterations=null"],  # one level
                 sweeps, OUT, [])

# %% [markdown]
# `study.csv` has one row per grid point. `hausdorff_final` is what the model says of
# itself, `hausdorff_reference` what the reference says of the same growth.

# %%
table = list(csv.DictReader(open(OUT / "study.csv"))) if rank0 else []
if rank0:
    print(f"{'mesh.size':>9} {'degree':>6} {'DOFs':>6} {'time s':>7} {'self %':>7} "
          f"{'reference %':>11}")
    for r in table:
        size = float(r["target_size"])
        print(f"{r['mesh.size']:>9} {r['model.degree']:>6} {r['dofs_state']:>6} "
              f"{float(r['wall_time_s']):7.1f} "
              f"{100 * float(r['hausdorff_final']) / size:7.2f} "
              f"{100 * float(r['hausdorff_reference']) / size:11.2f}")

# %% [markdown]
# ## The Pareto front
# The points that no other point beats in both time and error. (`study.png` in the
# output folder is the same plot, with every point labelled.)

# %%
if rank0:
    cost = np.array([float(r["wall_time_s"]) for r in table])
    error = np.array([float(r["relative_error_reference"]) for r in table])
    front = pareto_front(cost, error)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.loglog(cost, 100 * error, "o", color="0.6")
    ax.loglog(cost[front], 100 * error[front], "o-", color="C3", label="Pareto front")
    for r, c, e in zip(table, cost, error):
        ax.annotate(f"h={r['mesh.size']}, P{r['model.degree']}", (c, 100 * e), fontsize=8,
                    xytext=(4, 3), textcoords="offset points")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("shape error on the reference (%)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    plt.show()
