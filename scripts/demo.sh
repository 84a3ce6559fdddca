#!/usr/bin/env bash
# The main job on the bundled example: installs the dependencies, builds, then
# simulates the finger example (data/examples/finger) and evaluates a loss against
# another pose with its gradient with respect to every element's actuation.
# Results: out/finger/ (open the .vtu files in ParaView, the .obj in any viewer).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install_deps.sh
./scripts/build.sh
finger=data/examples/finger
out=out/finger
mkdir -p "$out"
echo "== Target pose: the muscle on the (0.6, 0.8) side"
build/apps/aqs_simulate --mesh=$finger/finger.msh --fixed=$finger/fixed.txt \
  --actuation=$finger/actuation_y.txt --output=$out/target.mesh,$out/target.vtu,$out/target.obj
echo "== Pose of the +x muscle, its loss against the target and dL/da"
build/apps/aqs_simulate --mesh=$finger/finger.msh --fixed=$finger/fixed.txt \
  --actuation=$finger/actuation.txt --output=$out/bent.mesh,$out/bent.vtu,$out/bent.obj \
  --loss_target=$out/target.mesh --gradient=$out/gradient.txt
echo "Results in $out/: bent.vtu and target.vtu (ParaView; fields displacement, actuation,"
echo "energy_density, volume_ratio, dL_da), bent.obj / target.obj (surfaces), gradient.txt."
