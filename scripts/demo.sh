#!/usr/bin/env bash
# The main job on the bundled example (data/ict-face-demo, a reduced ICT face):
# installs the dependencies, builds, then
#   1. aqs_pipeline: prepares the simulation mesh and volumetric targets, pre-trains the
#      decoder, trains it end to end through the simulator (5 minutes), and evaluates it
#      against a surface auto-encoder and PCA on 4 held-out expressions;
#   2. aqs_fit: fits the trained model (latent and jaw) to two expressions it never saw:
#      mouthClose (the lips pressed into each other) and the blend jawOpen+mouthClose
#      (lips closed over an opened jaw); and to a synthetic scan of a held-out one,
#      without and with its landmarks;
#   3. aqs_collide: re-solves jawOpen and the two fits with contact (teeth as obstacles,
#      the skin against itself), and reports penetrations and intersecting triangles
#      before and after.
# 8 to 18 minutes on 2 cores after the build (the README's run of 2026-12-06 took 9 min 28 s).
# Results in out/face_demo/: see the README.
# Arguments go to aqs_pipeline: ./scripts/demo.sh --restart starts the model anew (needed
# when configs/face_demo.flags changed since out/face_demo/model was made).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install_deps.sh
./scripts/build.sh
apps=build/apps
data=data/ict-face-demo
out=out/face_demo
model=$out/model
teeth="$data/teeth_neutral.obj vertices=0:2208, $data/teeth_neutral.obj vertices=2208:4412 bone=jaw"

echo "== 1. Learn the face model (prepare, pretrain, train, evaluate)"
$apps/aqs_pipeline --flagfile=configs/face_demo.flags "$@"

echo "== 2. Fit unseen expressions"
mkdir -p $out/collide
fit() {  # aqs_fit's flags; exit 2 (the fit failed or did not converge) is reported, not fatal
  $apps/aqs_fit --model=$model "$@" || {
    status=$?  # 2: finite results are still written (docs/apps.md)
    [ $status -eq 2 ] || exit $status
    echo "aqs_fit: the fit did not converge or failed (exit 2; see above); going on"
  }
}
for pose in mouthClose jawOpen+mouthClose; do
  rm -f $out/collide/$pose.txt  # an earlier run's latent must not pass for this one's
  fit --target=$data/poses/$pose.obj \
    --output=$out/collide/${pose}_fit.obj --latent_output=$out/collide/$pose.txt
done

echo "== 2b. Fit a scan: a partial, noisy point cloud of a held-out expression (no correspondence)"
fit --target=$data/scans/mouthFunnel_scan.ply \
  --output=$out/collide/mouthFunnel_scan_fit.obj \
  --compare_to=$data/poses/mouthFunnel.obj --compare_vertices=0:9409
echo "== 2c. The same scan with 10 landmarks (eye and mouth corners, lips, nose tip, chin)"
fit --target=$data/scans/mouthFunnel_scan.ply \
  --landmarks=$data/scans/mouthFunnel_landmarks.txt \
  --output=$out/collide/mouthFunnel_scan_landmarks_fit.obj \
  --compare_to=$data/poses/mouthFunnel.obj --compare_vertices=0:9409

echo "== 3. Contact: teeth against the opened jaw, lips against each other"
# Contact surface: the skin without the mouth socket the teeth are rooted in.
collide() {  # NAME, then --pose=... or --latent=...
  if [[ "$2" == --latent=* && ! -f "${2#--latent=}" ]]; then
    echo "aqs_collide $1: skipped (its fit wrote no latent)"
    return
  fi
  # An earlier run's outputs must not pass for this one's where this one writes none.
  rm -f $out/collide/$1.obj $out/collide/$1_before.obj $out/collide/$1_intersections.ply \
    $out/collide/$1_report.txt
  $apps/aqs_collide --model=$model "$2" --obstacles="$teeth" --contact_vertices=0:11248 \
    --output=$out/collide/$1.obj --output_before=$out/collide/$1_before.obj \
    --output_intersections=$out/collide/$1_intersections.ply \
    --report=$out/collide/$1_report.txt || {
    status=$?
    [ $status -eq 2 ] || exit $status
    if [ -f $out/collide/$1_report.txt ]; then  # the contact equilibrium missed its tolerance
      echo "aqs_collide $1: not converged to tolerance (see $out/collide/$1_report.txt)"
    else  # the pose could not be simulated, or the contact solve failed
      echo "aqs_collide $1: no contact result (exit 2; see above)"
    fi
  }
}
collide jawOpen --pose=jawOpen
collide mouthClose --latent=$out/collide/mouthClose.txt
collide jawOpen+mouthClose --latent=$out/collide/jawOpen+mouthClose.txt

echo
echo "Results in $out/:"
echo "  evaluation/index.html      the report: tables, error budget, pictures (open in a browser)"
echo "  evaluation/evaluation.md   errors of physics vs auto-encoder vs PCA, train and held out,"
echo "                             and the error budget (where the error comes from)"
echo "  evaluation/fields/*.ply    per-vertex error fields (viridis colours; MeshLab, ParaView)"
echo "  evaluation/fitted/*.obj    every method's surface for every pose"
echo "  model/                     the trained model (docs/model_format.md); model/train/log.csv"
echo "  collide/                   fits (*_fit.obj), surfaces with and without contact"
echo "                             (NAME.obj, NAME_before.obj), remaining intersections"
echo "                             (NAME_intersections.ply) and reports (NAME_report.txt)"
