"""What an energy costs (not a test: it prints ratios measured in one run).

    .venv/bin/python benchmarks/materials.py [--size 0.0125]

Builds the case ``shapegrowth bench`` measures at mesh size ``--size`` (scene 1's beam with a
growth near its optimum, solved from rest: 50 715 displacement DOFs at 0.0125) once per
material, and times, at the state found, a bare Newton iteration (the residual and the
tangent assembled, MUMPS LU, the update: ``bench.reference_newton_seconds``) and an adjoint
solve with fresh factors (the tangent assembled and factored), each the best of three, against
the paper's Mooney-Rivlin's.  The time of each solve from rest (its forms compiled first) is
printed too.
"""

from __future__ import annotations

import argparse
import time

from shapegrowth import compat, config
from shapegrowth.commands import bench, launch
from shapegrowth.optim.problem import ReducedFunctional
from shapegrowth.physics.model import ForwardModel
from shapegrowth.timing import Timer

CASES: dict[str, list[str]] = {
    "mooney_rivlin": [],
    "neo_hookean": ["material.kind=neo_hookean", "material.mu=1", "material.kappa=3.667"],
    "yeoh": ["material.kind=yeoh", "material.c10=0.5", "material.c20=0.05",
             "material.kappa=3.667"],
    "gent": ["material.kind=gent", "material.mu=1", "material.Jm=20", "material.kappa=3.667"],
    "ogden": ["material.preset=treloar_ogden"],
    "energy": ["material.kind=energy", "material.energy=0.5*(I1b - 3) + 0.5*(I2b - 3) "
               "+ 1.833*(J - 1)**2"],
    "mooney_rivlin, mixed": ["material.formulation=mixed"],
    "neo_hookean, incompressible": ["material.kind=neo_hookean", "material.mu=1",
                                    "material.incompressible=true"],
}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--size", type=float, default=0.0125)
    args = parser.parse_args()
    rows = []
    # the shipped config names the paper's constants, which the other energies do not take
    paper = ["material.mu1=null", "material.mu2=null", "material.lmbda=null"]
    for name, sets in CASES.items():
        own = sets if name.startswith("mooney_rivlin") else [*paper, *sets]
        cfg = config.load(launch.shipped_configs() / bench.DEFAULT_CONFIG,
                          [*bench.DEFAULT_OVERRIDES, f"mesh.size={args.size}", *own])
        model = ForwardModel.build(cfg)
        rf = ReducedFunctional(model, Timer())
        tic = time.perf_counter()
        rf.evaluate(rf.current())  # the state from rest (its forms compiled first)
        cold = time.perf_counter() - tic
        state = model.state
        # the best of three: the first of each pays once-only costs (MUMPS's set-up)
        newton = min(bench.reference_newton_seconds(model, iterations=1) for _ in range(3))
        rf.adjoint.reuse = False  # a fresh factorisation, as the adjoint's own solver makes
        dJdu = compat.petsc_vec(state.u).copy()
        dJdu.set(1e-3)
        adjoint = float("inf")
        for _ in range(3):
            tic = time.perf_counter()
            rf.adjoint.solve(dJdu)
            adjoint = min(adjoint, time.perf_counter() - tic)
        dofs = state.W.dofmap.index_map.size_global * state.W.dofmap.index_map_bs
        rows.append((name, dofs, newton, adjoint, cold))
        print(f"{name}: {dofs} DOFs, Newton iteration {newton:.3f} s, adjoint {adjoint:.3f} s, "
              f"from rest (forms compiled) {cold:.1f} s", flush=True)
    base = rows[0]
    print("\n| material | DOFs | Newton iteration | adjoint solve |\n|---|---|---|---|")
    for name, dofs, newton, adjoint, _ in rows:
        print(f"| {name} | {dofs} | {newton / base[2]:.2f}x | {adjoint / base[3]:.2f}x |")
    print(f"\nMooney-Rivlin: a Newton iteration {base[2]:.3f} s, an adjoint solve "
          f"{base[3]:.3f} s")


if __name__ == "__main__":
    main()
