#!/usr/bin/env bash
# The sweeps behind docs/MODELS.md's choices: one-at-a-time sweeps around a coarse base model of
# scene 1 (beam_wave), scene 4 (disk_cone) and scene 6 (square_circle, 2D against 3D), each
# optimum judged on a fine reference: one fine mesh (first sweeps), or each point's own
# mesh refined once (--reference mesh.refine=1, "nested"; the growth carries over exactly).
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
disk mesh_size --sweep mesh.size=0.3,0.2

# nested references: the discretisation error of each optimum's own state
beam mesh_size_nested --sweep mesh.size=0.1,0.05,0.035 --reference mesh.refine=1
beam graded_nested --set mesh.size=0.05 --sweep mesh.clamp_size=null,0.01 \
  --reference mesh.refine=1
beam design_nested --set mesh.size=0.05 --sweep "growth.eigenvalues.design=[1],[1,3],[1,2,3]" \
  --reference mesh.refine=1
beam filter_nested --set mesh.size=0.05 --sweep growth.filter_length=0,0.05,0.1 \
  --reference mesh.refine=1

disk_nested() {
  local name=$1; shift
  $SG study configs/disk_cone.yaml --out "$OUT/disk_cone/$name" -q \
    --set mesh.size=0.3 --set mesh.layers=1 --set optimizer.max_iterations=40 \
    --reference mesh.refine=1 "$@" || true
}
disk_nested optimizer_nested --sweep optimizer.algorithm=mma,slsqp
disk_nested degree_nested --sweep model.degree=1,2
disk_nested alpha_nested --sweep objective.hausdorff.alpha=50,100,200
disk_nested layers_nested --sweep mesh.layers=1,2
disk_nested design_nested --sweep "growth.eigenvalues.design=[1],[1,3],[1,2,3]"

# scene 6: plane strain against the 3D cube-to-cylinder it stands for (the shipped
# settings: alpha 1000, clouds of degree 4, SLSQP 300, start from the target's metric)
square() {
  local name=$1; shift
  $SG study configs/square_circle_fixed.yaml --out "$OUT/square_circle/$name" -q \
    --reference mesh.refine=1 "$@" || true
}
square plane_strain_alpha1000 --sweep mesh.size=1.0,0.5
square cube_alpha1000 --set geometry.kind=cube --set model.dim=3 \
  --set "growth.eigenvalues.design=[1,2,3]" \
  --set 'target.map=["3*x1*sqrt(1 - x2**2/8)", "3*x2*sqrt(1 - x1**2/8)", "x3"]' \
  --sweep mesh.size=1.0

# the shells: how coarse a model still follows its own optimum (short runs)
$SG study configs/cylinder_flare.yaml --out "$OUT/cylinder_flare/mesh_size_nested" -q \
  --set optimizer.max_iterations=40 --sweep mesh.size=0.2,0.1 --reference mesh.refine=1 || true
$SG study configs/tube_helix.yaml --out "$OUT/tube_helix/mesh_size_nested" -q \
  --set optimizer.max_iterations=30 --sweep mesh.size=1.0,0.7 --reference mesh.refine=1 || true
