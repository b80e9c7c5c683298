#!/usr/bin/env bash
# The main job end to end on the embedded default capture:
#   synth (default capture with ground truth) -> reconstruct -> relight the
#   held-out views -> evaluate against the held-out photos.
# Usage: scripts/demo.sh [out-dir]   (default: out/demo)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/demo}
scripts/setup.sh build
CLI=build/apps/svbrdf
mkdir -p "$OUT"
echo "== 1/4 synthesize the default capture"
"$CLI" synth --preset default --out "$OUT/capture"
echo "== 2/4 reconstruct"
"$CLI" reconstruct "$OUT/capture/scene.json" --out "$OUT/material"
echo "== 3/4 relight the held-out views"
"$CLI" relight "$OUT/material" "$OUT/capture/heldout/scene.json" --out "$OUT/relit" --preview
echo "== 4/4 evaluate against the held-out photos"
"$CLI" evaluate "$OUT/relit" "$OUT/capture/heldout/scene.json" | tee "$OUT/evaluation.txt"
echo "== export for other tools (Mitsuba 3 scene of the held-out views, glTF 2.0)"
"$CLI" export "$OUT/material" --format mitsuba --scene "$OUT/capture/heldout/scene.json" --out "$OUT/mitsuba"
"$CLI" export "$OUT/material" --format gltf --out "$OUT/gltf"
HDR=/usr/share/blender/datafiles/studiolights/world/studio.exr  # apt-get install blender-data (optional, 101 MB)
if [ -f "$HDR" ]; then
  echo "== relight the held-out views in an HDR environment ($HDR)"
  "$CLI" relight "$OUT/material" "$OUT/capture/heldout/scene.json" --out "$OUT/relit_env" --envmap "$HDR" --samples 16 --preview
fi
cat <<MSG

Results:
  capture (photos, masks, ground truth): $OUT/capture/
  reconstructed material:                $OUT/material/material.json
  report (cluster map, weights, confidence, residual, held-out photo vs relit): $OUT/material/report/
  summary:                               $OUT/material/report/summary.json
  relit held-out views (+ .preview.png): $OUT/relit/images/
  evaluation:                            $OUT/evaluation.txt
  report page (self-contained):          $OUT/material/report/report.html
  Mitsuba 3 scene (view_NNNN.xml):       $OUT/mitsuba/
  glTF 2.0 (model.gltf):                 $OUT/gltf/
  environment-lit views (if blender-data is installed): $OUT/relit_env/images/
MSG
