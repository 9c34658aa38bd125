#!/usr/bin/env bash
# The sweeps behind docs/TRADEOFFS.md: one-at-a-time sweeps around a coarse base model of
# scene 1 (beam_wave) and scene 2 (disk_cone), each optimum judged on one fine reference.
#   scripts/tradeoff_sweeps.sh [OUT]      (resumable: finished points are read back)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-results/tradeoffs}
SG=.venv/bin/shapegrowth

beam() {  # name, sweep...
  local name=$1; shift
  $SG study configs/beam_wave.yaml --out "$OUT/beam_wave/$name" -q \
    --set mesh.size=0.1 --set mesh.layers=2 --set optimizer.max_iterations=60 \
    --reference mesh.size=0.05 --reference mesh.layers=2 --reference model.degree=2 \
    --reference model.quadrature_degree=4 "$@" || true
}
disk() {
  local name=$1; shift
  $SG study configs/disk_cone.yaml --out "$OUT/disk_cone/$name" -q \
    --set mesh.size=0.2 --set mesh.layers=1 --set optimizer.max_iterations=40 \
    --reference mesh.size=0.1 --reference mesh.layers=2 --reference model.degree=2 \
    --reference model.quadrature_degree=4 "$@" || true
}

beam mesh_size --sweep mesh.size=0.2,0.1,0.07,0.05
beam mesh_size_fine_reference --sweep mesh.size=0.07,0.05 --reference mesh.size=0.035
beam filter_fine --set mesh.size=0.05 --sweep growth.filter_length=0.03,0.05 \
  --reference mesh.size=0.035
beam layers --sweep mesh.layers=1,2,3
beam degree --sweep model.degree=1,2
beam quadrature --sweep model.quadrature_degree=2,3,4,6
beam alpha --sweep objective.hausdorff.alpha=50,100,200,400
beam filter --sweep growth.filter_length=0,0.02,0.05
beam optimizer --sweep optimizer.algorithm=mma,slsqp
beam linear_solver --sweep solver.linear=mumps,gamg --set optimizer.max_iterations=10
disk mesh_size --sweep mesh.size=0.3,0.2,0.15
disk degree --sweep model.degree=1,2
disk alpha --sweep objective.hausdorff.alpha=50,100,200
disk optimizer --sweep optimizer.algorithm=mma,slsqp
