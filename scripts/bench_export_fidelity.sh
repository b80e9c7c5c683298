#!/usr/bin/env bash
# Export fidelity: does an exported material render like the reconstruction?
# On the demo capture (synth --preset default), for the unrestricted fit and
# `reconstruct --for mitsuba|gltf`: relight + evaluate against the held-out
# photos, Mitsuba 3 renders of `export --format mitsuba` against the same
# photos (scripts/check_mitsuba_export.py), Blender (Debian `blender`, Cycles)
# renders of `export --format gltf` against them (scripts/check_blender_gltf.py),
# and the glTF export's per-texel fit error. Writes bench_results/export_fidelity.json; the table in
# bench_results/export_fidelity.md cites it.
# Needs the Mitsuba 3 wheel: MI_PYTHON=/path/to/venv/bin/python (pip install mitsuba).
# Usage: scripts/bench_export_fidelity.sh [work-dir]   (default out/export_fidelity)
set -euo pipefail
cd "$(dirname "$0")/.."
W=${1:-out/export_fidelity}
CLI=build/apps/svbrdf
PY=${MI_PYTHON:-/work/scratch/mi/bin/python}
mkdir -p "$W"
[ -f "$W/capture/scene.json" ] || "$CLI" synth --preset default --out "$W/capture"
for t in any mitsuba gltf; do
  start=$(date +%s%N)
  "$CLI" reconstruct "$W/capture/scene.json" --out "$W/mat_$t" --for $t > "$W/reconstruct_$t.log" 2>&1
  echo "$(( ($(date +%s%N) - start) / 1000000 ))" > "$W/reconstruct_$t.ms"
  "$CLI" relight "$W/mat_$t" "$W/capture/heldout/scene.json" --out "$W/relit_$t" > /dev/null
  "$CLI" evaluate "$W/relit_$t" "$W/capture/heldout/scene.json" > "$W/evaluate_$t.txt"
  "$CLI" export "$W/mat_$t" --format gltf --out "$W/gltf_$t" > /dev/null
  if command -v blender > /dev/null; then
    /usr/bin/python3 scripts/check_blender_gltf.py "$W/gltf_$t/model.gltf" "$W/capture/heldout/scene.json" --work "$W/blender_$t" --spp 64 > "$W/blender_$t.log"
  fi
  if [ "$t" != gltf ]; then
    "$PY" scripts/check_mitsuba_export.py "$W/mat_$t" "$W/capture/heldout/scene.json" --work "$W/mitsuba_$t" --spp 64 > "$W/mitsuba_$t.log"
  fi
done
/usr/bin/python3 - "$W" <<'PY'
import json, re, sys, os
w = sys.argv[1]
out = {"capture": "synth --preset default (held-out views: capture/heldout)", "runs": {}}
for t in ("any", "mitsuba", "gltf"):
    r = {}
    m = re.search(r"mean PSNR ([\d.]+) dB \(min ([\d.]+)\)", open(f"{w}/evaluate_{t}.txt").read())
    r["relight_vs_photos_psnr"] = float(m.group(1)); r["relight_vs_photos_min"] = float(m.group(2))
    mat = json.load(open(f"{w}/mat_{t}/material.json"))
    r["models"] = [b.get("model") for b in mat.get("basis", [])]
    r["reconstruct_s"] = round(int(open(f"{w}/reconstruct_{t}.ms").read()) / 1000, 1)
    g = json.load(open(f"{w}/gltf_{t}/export_report.json"))["fit"]
    r["gltf_fit_relative_error_mean"] = g["relative_error_mean"]; r["gltf_fit_relative_error_p95"] = g["relative_error_p95"]
    if os.path.exists(f"{w}/mitsuba_{t}/agreement.json"):
        a = json.load(open(f"{w}/mitsuba_{t}/agreement.json"))
        r["mitsuba_vs_photos_psnr"] = a["photos_mask"]["mean_psnr_srgb"]
        r["mitsuba_vs_relight_psnr"] = a["material_mask"]["mean_psnr_srgb"]
        r["mitsuba_version"] = a["mitsuba"]
        r["exact_forms"] = [b["exact"] for b in a["export_report"]["basis"]]
    if os.path.exists(f"{w}/blender_{t}/blender_agreement.json"):
        b = json.load(open(f"{w}/blender_{t}/blender_agreement.json"))
        r["blender_gltf_vs_photos_psnr"] = b["mean_psnr_srgb"]; r["blender_gltf_vs_photos_min"] = b["min_psnr_srgb"]
    out["runs"][t] = r
os.makedirs("bench_results", exist_ok=True)
json.dump(out, open("bench_results/export_fidelity.json", "w"), indent=2)
print(json.dumps(out, indent=2))
PY
