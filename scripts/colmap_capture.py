#!/usr/bin/env python3
"""COLMAP structure from motion on a synthetic raw photo set (issue 10, poses
by SfM): `svbrdf synth-raw`, then `svbrdf capture` with "poses": "colmap".
Reports how COLMAP's model, placed in the board frame by a similarity, agrees
with the board poses, and the CPU time of the run. Not a ctest: COLMAP takes
~25 s CPU on 12 photos of 480x360.

Usage: scripts/colmap_capture.py BUILD_DIR [OUT_PREFIX]   (writes OUT_PREFIX.json/.md)
"""
import json, os, resource, shutil, subprocess, sys, tempfile

build = sys.argv[1] if len(sys.argv) > 1 else "build"
prefix = sys.argv[2] if len(sys.argv) > 2 else "bench_results/colmap_capture"
cli = os.path.join(build, "apps", "svbrdf")
work = tempfile.mkdtemp(prefix="svbrdf_colmap_bench_")
try:
    raw, cap = os.path.join(work, "raw"), os.path.join(work, "capture")
    subprocess.run([cli, "synth-raw", "--out", raw, "--images", "12", "--calibration", "12", "--lamps", "3",
                    "--heldout", "0"], check=True, stdout=subprocess.DEVNULL)
    desc = json.load(open(os.path.join(raw, "capture.json")))
    desc["poses"] = "colmap"
    json.dump(desc, open(os.path.join(raw, "capture_colmap.json"), "w"))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([cli, "capture", raw, "--description", os.path.join(raw, "capture_colmap.json"), "--out", cap],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    report = json.load(open(os.path.join(cap, "report", "capture_report.json")))
    result = {"photos": 12, "size": "480x360", "colmap": report["colmap"],
              "capture_cpu_s": round(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, 1),
              "stage_wall_s": report["seconds"]}
    json.dump(result, open(prefix + ".json", "w"), indent=2)
    c = report["colmap"]
    with open(prefix + ".md", "w") as f:
        f.write("# COLMAP SfM in `svbrdf capture` (synthetic raw set, 12 photos 480x360)\n\n")
        f.write("| registered | 3D points | placed by board photos | scale (m per COLMAP unit) | centre RMS after placing | "
                "worst vs board pose | capture CPU |\n|---|---|---|---|---|---|---|\n")
        f.write(f"| {c['registered_images']}/12 | {c['points']} | {c['placed_by_board_photos']} | {c['scale']:.4f} | "
                f"{c['centre_rms_mm']:.2f} mm | {c['vs_board_worst_deg']:.3f} deg, {c['vs_board_worst_mm']:.2f} mm | "
                f"{result['capture_cpu_s']} s |\n")
    print(open(prefix + ".md").read())
finally:
    shutil.rmtree(work, ignore_errors=True)
