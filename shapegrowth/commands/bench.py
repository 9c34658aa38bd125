"""``shapegrowth bench``: the cost of one optimisation iteration and where it goes.

Each case is one mesh size of one scene, measured in a process of its own (so that
its peak memory is its own): the state is first solved from rest for a growth near
the optimum (cold), then ``steps`` iterations follow, each a design step of
``step_size`` (relative, in a smooth direction) with J and dJ/dm evaluated as the
optimiser would: warm-started state, rho_H, adjoint, sensitivities, filters.
The harness then runs the largest case again under ``mpirun -n RANKS``.

Reference for the Newton solver: a minimal hand-written Newton loop (assemble the
residual and the tangent, MUMPS LU, update) on the same forms and mesh, so the
ratio ``newton_over_reference`` is what the solver machinery (SNES, continuation,
predictor) costs beyond the bare algebra.
"""

from __future__ import annotations

import json
import logging
import sys
import time
from pathlib import Path
from typing import Any

import dolfinx.fem.petsc
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .. import blas, compat
from ..config import Config
from ..errors import InputError, StateSolveError
from ..io import files as io
from ..optim.problem import ReducedFunctional
from ..optim.taylor import smooth_direction
from ..physics.boundary import body_box
from ..physics.model import ForwardModel
from ..timing import Timer, peak_memory_mb
from . import launch

log = logging.getLogger(__name__)

# A growth near the optimum of scene 1 (exact Hausdorff error 8 % of the target size at
# mesh size 0.05, where an optimised one reaches 1 %): lambda_1 = (s (1 - kappa x3))^2
# bends the beam with curvature kappa and stretches its axis by s.  The wave (5.14),
# w = 0.15 sin(2 pi x1), has slope 0.94 cos(2 pi x1) and curvature -5.92 sin(2 pi x1);
# the clamp holds the end level, so a kink of 0.94 rad near X1 = 0 comes first, and
# s = sqrt(1 + w'^2) is the arc length of the wave per unit X1.
BEAM_WAVE_GROWTH = ("((1 + (0.94*cos(2*pi*x1))**2)**0.5"
                    "*(1 - x3*(21.2*exp(-(x1/0.05)**2) - 5.92*sin(2*pi*x1))))**2")
DEFAULT_SIZES = (0.05, 0.025, 0.0125)
# the process that measures one case (a module of its own, not a command-line flag)
CASE_WORKER = "shapegrowth.commands.bench_case"
DEFAULT_CONFIG = "beam_wave.yaml"  # in launch.shipped_configs()
DEFAULT_OVERRIDES = [f'growth.eigenvalues.initial=["{BEAM_WAVE_GROWTH}", 1.0, 1.0]']


def reference_newton_seconds(model: ForwardModel, iterations: int = 3) -> float:
    """Seconds per iteration of a bare Newton loop (the state's own residual and tangent
    assembly, MUMPS LU, update; no SNES, line search or continuation), started from (and
    restored to) the current equilibrium."""
    st = model.state
    A = dolfinx.fem.petsc.create_matrix(st.jacobian_form)
    b = compat.create_vector(st.residual_form)
    du = A.createVecRight()
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    saved = st.snapshot()
    x = compat.petsc_vec(st.w)  # the unknown (a mixed body's displacement and pressure)
    tic = time.perf_counter()
    for _ in range(iterations):
        st.assemble_residual(x, b)
        st.assemble_tangent(x, A)
        ksp.setOperators(A)
        ksp.solve(b, du)
        x.axpy(-1.0, du)
        st.w.x.scatter_forward()
    seconds = (time.perf_counter() - tic) / iterations
    st.put_back(saved)
    for obj in (ksp, A, b, du):
        obj.destroy()
    return seconds


def _evaluate(rf: ReducedFunctional, m: np.ndarray, cfg: Config):
    try:
        return rf.evaluate(m)
    except StateSolveError as err:
        raise InputError(f"bench: no equilibrium for the bench's growth at mesh size "
                         f"{cfg.mesh.size:g} ({err}); check the solver.* settings") from None


def measure_case(cfg: Config, steps: int = 3, step_size: float = 0.01) -> dict[str, Any]:
    """One case, in this process (all ranks)."""
    timer = Timer()
    model = ForwardModel.build(cfg)
    rf = ReducedFunctional(model, timer)
    comm = rf.comm
    m = rf.current()
    lo, hi = rf.bounds()

    tic = time.perf_counter()
    first = _evaluate(rf, m, cfg)
    cold_s = time.perf_counter() - tic
    cold_forward = first.report.seconds
    cold_newton = first.report.newton_iterations

    box_lo, box_hi = body_box(model.domain.mesh)  # of the whole body: the same on every rank
    direction = smooth_direction(rf.design_coordinates(), seed=1,
                                 length=float((box_hi - box_lo).max()))
    rows = []
    for _ in range(steps):
        m = np.clip(m * (1.0 + step_size * direction), lo, hi)
        before, details = dict(timer.totals), dict(timer.details)
        tic = time.perf_counter()
        ev = _evaluate(rf, m, cfg)
        elapsed = time.perf_counter() - tic
        spent = {key: timer.totals[key] - before[key] for key in before}
        detail = {key: timer.details.get(key, 0.0) - details.get(key, 0.0)
                  for key in timer.details}
        rows.append({"iteration_s": elapsed, "forward_s": ev.report.seconds,
                     "newton_iterations": ev.report.newton_iterations,
                     "hausdorff_s": spent["hausdorff"],
                     "adjoint_s": detail.get("adjoint_solve", 0.0),
                     "sensitivities_s": detail.get("sensitivities", 0.0),
                     "filter_s": spent["filter"],
                     "filter_backward_s": detail.get("filter_backward", 0.0)})
    # every rank measured its own clock: the slowest rank's times, and ratios made of them
    mean = {key: comm.allreduce(float(np.mean([r[key] for r in rows])), MPI.MAX)
            for key in rows[0]}
    newton_s = mean["forward_s"] / max(mean["newton_iterations"], 1e-300)
    reference = comm.allreduce(reference_newton_seconds(model), MPI.MAX)
    case = {
        "mesh_size": cfg.mesh.size,
        "dofs": compat.global_size(model.state.V),
        "design_dofs": comm.allreduce(rf.size, MPI.SUM),
        "points": comm.allreduce(len(rf.objective.cloud), MPI.SUM),
        "ranks": comm.size,
        "blas_kernels": blas.loaded_openblas_kernels(),  # OpenBLAS's, None for another BLAS
        "objective": ev.value.total,  # at the last step: the same on any number of ranks
        "adjoint_refinements": rf.adjoint.refinements,
        "cold_forward_s": cold_forward,
        "cold_newton_iterations": cold_newton,
        "cold_iteration_s": cold_s,
        **mean,
        "newton_iteration_s": newton_s,
        "reference_newton_iteration_s": reference,
        "newton_over_reference": newton_s / reference,
        "gradient_over_forward": (mean["adjoint_s"] + mean["sensitivities_s"]
                                  + mean["filter_backward_s"]) / mean["forward_s"],
        "hausdorff_over_iteration": mean["hausdorff_s"] / mean["iteration_s"],
        "peak_memory_mb": peak_memory_mb(comm),  # the case has its process to itself
        "steps": rows,
    }
    return case


def run_case_process(config: Path, overrides: list[str], size: float, out: Path,
                      ranks: int, one_thread: bool = False) -> dict[str, Any]:
    """Runs one case in a fresh process (under mpirun when ranks > 1) and reads its json.
    ``one_thread``: one BLAS and one numba thread (what each MPI rank gets)."""
    out.mkdir(parents=True, exist_ok=True)
    args = launch.with_sets([config, "--out", out], [f"mesh.size={size}", *overrides])
    # under mpirun one BLAS thread per rank (numba's is set by the package per rank)
    env = {"OPENBLAS_NUM_THREADS": "1"} if ranks > 1 else None
    done = launch.launch(args, ranks, program=[sys.executable, "-m", CASE_WORKER],
                         one_thread=one_thread, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        said = [line for line in done.stderr.splitlines() if line.startswith("error: ")]
        if said:  # the case's own one-line error
            raise InputError(said[-1].removeprefix("error: "))
        raise RuntimeError(f"bench case h = {size} on {ranks} rank(s) failed:\n"
                           f"{done.stderr[-3000:]}")
    return json.loads((out / "case.json").read_text())


def scaling_exponent(dofs: list[float], seconds: list[float]) -> float:
    """Slope of log(seconds) against log(dofs), least squares."""
    return float(np.polyfit(np.log(dofs), np.log(seconds), 1)[0])


def run_bench(config: Path, overrides: list[str], out: Path, sizes: list[float],
              ranks: int) -> dict[str, Any]:
    cases = []
    for size in sizes:
        log.info("bench: mesh size %g on 1 rank ...", size)
        case = run_case_process(config, overrides, size, out / f"case-{size:g}", 1)
        log.info("  %d DOFs, %d points: iteration %.3g s (forward %.3g s, %.1f Newton), "
                 "adjoint %.3g s, rho_H %.3g s", case["dofs"], case["points"],
                 case["iteration_s"], case["forward_s"], case["newton_iterations"],
                 case["adjoint_s"], case["hausdorff_s"])
        cases.append(case)
    largest = max(cases, key=lambda c: c["dofs"])
    result: dict[str, Any] = {
        "config": str(config), "overrides": overrides, "cases": cases,
        "ratios": {
            "gradient_over_forward": max(c["gradient_over_forward"] for c in cases),
            "hausdorff_over_iteration": max(c["hausdorff_over_iteration"] for c in cases),
            "newton_over_reference": max(c["newton_over_reference"] for c in cases),
        },
        "newton_iterations_per_step": float(np.mean([c["newton_iterations"] for c in cases])),
        "scaling_exponent": scaling_exponent([c["dofs"] for c in cases],
                                             [c["iteration_s"] for c in cases]),
        "mpi": {"ranks": ranks},
    }
    if ranks > 1:
        log.info("bench: mesh size %g on %d ranks ...", largest["mesh_size"], ranks)
        parallel = run_case_process(config, overrides, largest["mesh_size"],
                                     out / f"case-{largest['mesh_size']:g}-np{ranks}", ranks)
        # The serial run already uses every core through threads (OpenBLAS in MUMPS,
        # numba in rho_H); against one thread the speedup is that of the ranks alone.
        log.info("bench: mesh size %g on 1 rank, one thread ...", largest["mesh_size"])
        single = run_case_process(config, overrides, largest["mesh_size"],
                                   out / f"case-{largest['mesh_size']:g}-1thread", 1,
                                   one_thread=True)
        result["mpi"].update({"dofs": parallel["dofs"], "iteration_s": parallel["iteration_s"],
                              "serial_iteration_s": largest["iteration_s"],
                              "speedup": largest["iteration_s"] / parallel["iteration_s"],
                              "one_thread_iteration_s": single["iteration_s"],
                              "speedup_over_one_thread":
                                  single["iteration_s"] / parallel["iteration_s"],
                              "forward_speedup": largest["forward_s"] / parallel["forward_s"],
                              "case": parallel, "one_thread_case": single})
    update_bench_json(out, result, keep=("runs", "scaling"))
    return result


def update_bench_json(out: Path, entries: dict[str, Any],
                      keep: tuple[str, ...] | None = None) -> Path:
    """Write ``entries`` into ``out``/bench.json over what it holds: every other key kept
    (``keep`` None) or only those named (the per-iteration bench rewrites its own keys and
    keeps those of ``--runs`` and ``--scaling``)."""
    path = out / "bench.json"
    previous = io.read_json(path) if path.is_file() else {}
    kept = {k: v for k, v in previous.items() if keep is None or k in keep}
    io.write_json(path, {**kept, **entries})
    return path
