#!/usr/bin/python3
"""Generalization benchmark (issue 24): the reconstruction on randomized
Mitsuba 3 captures that it was not tuned to.

The scene set is frozen in bench_results/generalization_scenes.json (written
by `scripts/mitsuba_scenes.py --freeze`): 24 seeds, their drawn parameters,
their split (odd seeds = dev, even seeds = test) and the sha256 of the
sampler's sources. This script refuses to run when the sampler's sources no
longer hash to the manifest's value, or when a capture renders other
parameters than the manifest's, unless --allow-resample (then the results say
that the scenes were re-drawn and do not compare with earlier ones).

Per scene of the chosen half: renders the capture into CACHE/<seed>/ if it
is missing (scripts/mitsuba_scenes.py in the Mitsuba venv), then
  svbrdf reconstruct CAP/scene.json --out RUNS/<seed>/material --threads N
      (wall time and peak memory from /usr/bin/time -v)
  svbrdf relight RUNS/<seed>/material CAP/heldout/scene.json --out RUNS/<seed>/relit --bounces 2
  svbrdf evaluate RUNS/<seed>/relit CAP/heldout/scene.json
and reads the basis materials chosen from RUNS/<seed>/material/report/summary.json
against the true count. Ceiling: the truth's own relight, i.e. Mitsuba
rendering the held-out views again with the true scene, an independent sampler
seed, 64 spp and no added noise (CAP/truth/ceiling/, made with the capture),
scored by the same `svbrdf evaluate` against the held-out photos: only the
photos' noise (Monte Carlo at 32 spp + the drawn relative noise) and the
re-render's Monte Carlo noise separate it from them.

Writes bench_results/generalization.{md,json,png}; the dev and test halves are
separate keys of the JSON and sections of the markdown (a run updates only
its half). The test half is for the final measurement only: tune on dev.

Usage:
  /usr/bin/python3 scripts/bench_generalization.py --half dev
      [--cache /work/scratch/gen] [--runs /work/scratch/gen_runs] [--threads 2]
      [--mitsuba-python /work/scratch/mi/bin/python] [--seeds 1,3] [--allow-resample]
      [--relight "--bounces 2"] [-- extra reconstruct options]
  /usr/bin/python3 scripts/bench_generalization.py --half extra|fresh|unseen [--extra-seeds A-B] ...   # seeds beyond the 24
  /usr/bin/python3 scripts/bench_generalization.py --half dev --report-only   # rewrite .md/.png from .json
Run it niced on a shared machine: `nice -n 5 /usr/bin/python3 scripts/bench_generalization.py --half dev`.
"""
import argparse
import datetime
import json
import os
import shlex
import shutil
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import bench  # noqa: E402
import mitsuba_scenes  # noqa: E402

ROOT = bench.ROOT
MANIFEST = os.path.join(ROOT, "bench_results", "generalization_scenes.json")
OUT = os.path.join(ROOT, "bench_results", "generalization")
CEILING = ("the truth's own relight: Mitsuba renders the held-out views again from the true scene with an "
           "independent sampler seed, 64 spp, no added noise (CAP/truth/ceiling/), scored by the same "
           "`svbrdf evaluate` against the held-out photos. The re-render carries its own Monte Carlo noise, so a "
           "noise-free relight can score above it (by up to ~1.8 dB where the photos' Monte Carlo noise dominates, "
           "e.g. scans whose normals turn within a pixel); a gap below zero means the reconstruction is within "
           "render noise of the truth")


# Halves beyond the frozen 24 seeds, drawn later by the same sampler, and
# what they are for (the markdown says it under each).
DRAWN_LATER = {
    "extra": "Seeds %d-%d, drawn by the same sampler after the 24 were frozen: more development scenes, first "
             "measured before any method was changed for them; not a replacement for the test half.",
    "fresh": "Seeds %d-%d, drawn by the same sampler after seeds 25-36 had become development scenes, rendered and "
             "first measured with the methods as they stood (binary of 5d7b6cc, 2026-12-06; docs/measurements.md, "
             "\"Seeds 37-48\": mean gap 3.07 dB against 0.52 on the dev half). The mirror stage's trimmed test came "
             "after that first run, from three of these scenes' logs (38, 40, 43): since then the set is development "
             "data too, not a replacement for the test half.",
    "unseen": "Seeds %d-%d, drawn by the same sampler after seeds 37-48 had become development scenes, rendered and "
              "first measured with the methods as they stood (binary of 3940b32, 2026-12-06), before any method "
              "was changed: mean 40.00 dB, gap 2.02 dB (worst 11.97, seed 57: 1 material of 5), count right 10 of "
              "12, 10.6 / 16.0 s. The split search's control test changed after that first run, from seed 57's log "
              "(docs/measurements.md, \"Seeds 49-60\"): since then the set is development data too, not a "
              "replacement for the test half.",
}
DEFAULT_SEEDS = {"extra": "25-36", "fresh": "37-48", "unseen": "49-60"}
HALVES = ("dev", "test") + tuple(DRAWN_LATER)


def load_manifest(path, allow_resample):
    manifest = json.load(open(path))
    current = mitsuba_scenes.sampler_hash()
    if manifest["sampler_sha256"] != current:
        if not allow_resample:
            sys.exit("bench_generalization: the sampler's sources (%s) hash to %s, the frozen manifest %s says %s: "
                     "the scenes would differ. Re-run with --allow-resample to measure re-drawn scenes (not "
                     "comparable with earlier results)." % (", ".join(manifest["sampler_sources"]), current[:12],
                                                             path, manifest["sampler_sha256"][:12]))
        for s in manifest["scenes"]:
            s["params"] = mitsuba_scenes.draw_scene(s["seed"])
        manifest["resampled_with"] = current
    return manifest


def ensure_capture(scene, cache, mi_python, allow_resample, log):
    """The capture folder of a manifest scene, rendered if missing or stale; returns (path, render info)."""
    cap = os.path.join(cache, str(scene["seed"]))
    params_path = os.path.join(cap, "truth", "scene_params.json")
    fresh = os.path.exists(os.path.join(cap, "truth", "render.json")) and os.path.exists(params_path)
    if fresh and json.load(open(params_path)) != scene["params"]:
        if not allow_resample:
            sys.exit("bench_generalization: %s holds other parameters than the manifest's seed %d; delete it to "
                     "render again" % (cap, scene["seed"]))
        fresh = False
    if not fresh:
        print("  rendering seed %d -> %s" % (scene["seed"], cap), flush=True)
        bench.run([mi_python, os.path.join(HERE, "mitsuba_scenes.py"), str(scene["seed"]), "--out", cap], log)
        if json.load(open(params_path)) != scene["params"]:
            sys.exit("bench_generalization: seed %d rendered other parameters than the manifest's (numpy or the "
                     "CGAL data differ?)" % scene["seed"])
    return cap, json.load(open(os.path.join(cap, "truth", "render.json")))


def describe(p):
    shape = p["shape"]
    name = shape.get("name", shape["kind"]) + ("" if shape["uvs"] else " (no UVs)")
    fams = ", ".join(m["family"] for m in p["materials"])
    return {"shape": name, "materials": fams, "blend": p["blend"]["kind"] if p["true_count"] > 1 else "-",
            "lights": "+".join(p["lights"]["mix"]), "photos": "%d + %d" % (p["views"], p["heldout"]),
            "noise_pct": round(100 * p["noise"], 2)}


def measure(scene, cap, work, binary, threads, relight_opts, recon_extra):
    os.makedirs(work, exist_ok=True)
    log = os.path.join(work, "log.txt")
    mat, relit = os.path.join(work, "material"), os.path.join(work, "relit")
    for d in (mat, relit):
        shutil.rmtree(d, ignore_errors=True)
    heldout = os.path.join(cap, "heldout", "scene.json")
    r = {}
    r["reconstruct_wall_s"], _, r["reconstruct_peak_rss_mb"] = bench.run(
        [binary, "reconstruct", os.path.join(cap, "scene.json"), "--out", mat, "--threads", str(threads)]
        + list(recon_extra), log, timed_rss=True)
    summary = json.load(open(os.path.join(mat, "report", "summary.json")))
    shutil.copy(os.path.join(mat, "report", "summary.json"), os.path.join(work, "summary.json"))
    r["materials_chosen"] = summary.get("clusters", len(summary.get("basis", [])))
    r["chosen_labels"] = [b.get("label") for b in summary.get("basis", [])]
    r["reconstruct_cpu_s"] = summary.get("cpu_s")
    r["relight_s"], _, _ = bench.run([binary, "relight", mat, heldout, "--out", relit] + relight_opts, log)
    _, out, _ = bench.run([binary, "evaluate", relit, heldout], log)
    ev = bench.parse_evaluate(out)
    r["psnr_db"], r["psnr_min_db"] = ev["psnr_mean_db"], ev["psnr_min_db"]
    r["per_view_psnr_db"] = [e["psnr_db"] for e in ev["per_image"]]
    return r


def ceiling(cap, binary, log):
    _, out, _ = bench.run([binary, "evaluate", os.path.join(cap, "truth", "ceiling"),
                           os.path.join(cap, "heldout", "scene.json")], log)
    ev = bench.parse_evaluate(out)
    return ev["psnr_mean_db"], ev["psnr_min_db"]


def summarize(rows):
    ok = [r for r in rows if r.get("psnr_db") is not None]
    s = {"scenes": len(rows), "failed": len(rows) - len(ok)}
    if ok:
        psnr = [r["psnr_db"] for r in ok]
        gap = [r["ceiling_db"] - r["psnr_db"] for r in ok if r.get("ceiling_db") is not None]
        s.update(psnr_mean_db=float(np.mean(psnr)), psnr_worst_db=float(np.min(psnr)),
                 worst_seed=ok[int(np.argmin(psnr))]["seed"],
                 ceiling_mean_db=float(np.mean([r["ceiling_db"] for r in ok])),
                 gap_mean_db=float(np.mean(gap)), gap_worst_db=float(np.max(gap)),
                 counts_right=sum(r["materials_chosen"] == r["true_count"] for r in ok),
                 wall_mean_s=float(np.mean([r["reconstruct_wall_s"] for r in ok])),
                 wall_max_s=float(np.max([r["reconstruct_wall_s"] for r in ok])),
                 rss_max_mb=float(np.max([r["reconstruct_peak_rss_mb"] or 0 for r in ok])))
    return s


def write_markdown(doc, path):
    L = ["# Generalization: randomized Mitsuba 3 captures", "",
         "Scenes: [generalization_scenes.json](generalization_scenes.json), %d seeds drawn by "
         "`scripts/mitsuba_scenes.py` and frozen on %s (sampler sha256 `%s`, %s). Run by "
         "`scripts/bench_generalization.py`; per scene: `reconstruct` -> `relight %s` of the held-out views -> "
         "`evaluate` (sRGB PSNR inside the masks)." % (doc["scene_count"], doc["frozen"], doc["sampler_sha256"][:12],
                                                       doc["split_rule"], doc["relight_options"]),
         "", "**Ceiling**: %s." % doc["ceiling"], ""]
    for half in HALVES:
        h = doc["halves"].get(half)
        if half in DRAWN_LATER and not h:
            continue
        if not h:
            L += ["## %s half" % half, "", "Not measured.", ""]
            continue
        s = h["summary"]
        if half in DRAWN_LATER:
            L += ["## %s half (measured %s)" % (half, h["env"]["date_utc"]), "",
                  DRAWN_LATER[half] % (min(r["seed"] for r in h["scenes"]), max(r["seed"] for r in h["scenes"])), ""]
        else:
            L += ["## %s half (measured %s)" % (half, h["env"]["date_utc"]), ""]
        L += [
              "Environment: %s. Reconstruct `--threads %d`%s." % (bench.env_note(h["env"]), h["threads"],
                                                                  (" " + " ".join(h["reconstruct_extra"]))
                                                                  if h["reconstruct_extra"] else ""),
              "Captures cached in `%s/<seed>/`, per-scene folders (material, relit, summary.json, log.txt) in "
              "`%s/<seed>/` (not committed)%s." % (h["cache"], h["runs"],
                                                   "; **partial**: not every seed of the half measured" if h["partial"] else ""),
              ""]
        if h.get("resampled_with"):
            L += ["**Re-drawn scenes** (sampler sha256 `%s` differs from the frozen one): not comparable." %
                  h["resampled_with"][:12], ""]
        if "psnr_mean_db" in s:
            L += ["| quantity | value |", "|---|---|",
                  "| held-out PSNR, mean / worst | %.2f / %.2f dB (seed %d) |" % (s["psnr_mean_db"], s["psnr_worst_db"],
                                                                            s["worst_seed"]),
                  "| ceiling, mean | %.2f dB |" % s["ceiling_mean_db"],
                  "| gap to the ceiling, mean / worst | %.2f / %.2f dB |" % (s["gap_mean_db"], s["gap_worst_db"]),
                  "| material count right | %d of %d |" % (s["counts_right"], s["scenes"] - s["failed"]),
                  "| reconstruct wall, mean / max | %.1f / %.1f s |" % (s["wall_mean_s"], s["wall_max_s"]),
                  "| peak memory, max | %.0f MB |" % s["rss_max_mb"],
                  "| failed | %d |" % s["failed"], ""]
        L += ["| seed | shape | true materials | blend | lights | photos | noise % | PSNR (min) | ceiling | gap | "
              "chosen / true | wall s | MB | render s |",
              "|---:|---|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in h["scenes"]:
            d = r["scene"]
            if r.get("error"):
                res = "failed | %s | | - / %d | | " % (bench.fmt(r.get("ceiling_db")), r["true_count"])
            else:
                res = "%.2f (%.2f) | %.2f | %.2f | %d / %d | %.1f | %.0f" % (
                    r["psnr_db"], r["psnr_min_db"], r["ceiling_db"], r["ceiling_db"] - r["psnr_db"],
                    r["materials_chosen"], r["true_count"], r["reconstruct_wall_s"], r["reconstruct_peak_rss_mb"] or 0)
            L.append("| %d | %s | %s | %s | %s | %s | %.2f | %s | %s |" % (
                r["seed"], d["shape"], d["materials"], d["blend"], d["lights"], d["photos"], d["noise_pct"], res,
                bench.fmt(r.get("render_s"), ".0f")))
        errors = [r for r in h["scenes"] if r.get("error")]
        if errors:
            L += [""] + ["- seed %d failed: %s" % (r["seed"], r["error"]) for r in errors]
        L.append("")
    L += ["Chart: [generalization.png](generalization.png) (PSNR per scene vs ceiling; reconstruct wall time).", ""]
    open(path, "w").write("\n".join(L))


def write_chart(doc, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    halves = [h for h in HALVES if doc["halves"].get(h)]
    fig, axes = plt.subplots(len(halves), 2, figsize=(12, 3.8 * len(halves)), squeeze=False,
                             gridspec_kw={"width_ratios": [2, 1]})
    for row, half in enumerate(halves):
        rows = doc["halves"][half]["scenes"]
        x = np.arange(len(rows))
        labels = [str(r["seed"]) for r in rows]
        psnr = [r.get("psnr_db") or 0 for r in rows]
        ceil = [r.get("ceiling_db") or 0 for r in rows]
        ax = axes[row][0]
        ax.bar(x - 0.2, ceil, 0.4, label="ceiling (Mitsuba re-render)", color="#bbbbbb")
        ax.bar(x + 0.2, psnr, 0.4, label="reconstruction", color="#3070b0")
        for i, r in enumerate(rows):
            if r.get("materials_chosen") is not None:
                ax.text(x[i] + 0.2, psnr[i] + 0.3, "%d/%d" % (r["materials_chosen"], r["true_count"]), ha="center",
                        fontsize=7)
        ax.set_xticks(x, labels)
        ax.set_xlabel("seed (label: materials chosen / true)")
        ax.set_ylabel("held-out PSNR (dB)")
        lo = min([v for v in psnr + ceil if v > 0] or [0])
        ax.set_ylim(max(0, lo - 5), max(ceil + psnr) + 3)
        ax.set_title("%s half: held-out PSNR per scene" % half)
        ax.legend(fontsize=8, loc="lower right")
        ax = axes[row][1]
        ax.bar(x, [r.get("reconstruct_wall_s") or 0 for r in rows], color="#b07030")
        ax.set_xticks(x, labels)
        ax.set_xlabel("seed")
        ax.set_ylabel("reconstruct wall (s)")
        ax.set_title("%s half: reconstruction time" % half)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--half", choices=["dev", "test", "all"] + list(DRAWN_LATER), required=True,
                    help="extra, fresh, unseen: seeds beyond the frozen 24 (--extra-seeds), drawn by the same sampler; "
                         "never a replacement for the test half (see DRAWN_LATER)")
    ap.add_argument("--extra-seeds", help="with --half extra, fresh or unseen: seed range A-B (A > 24); default %s" %
                    ", ".join("%s %s" % (h, r) for h, r in DEFAULT_SEEDS.items()))
    ap.add_argument("--cache", default="/work/scratch/gen", help="rendered captures, CACHE/<seed>/")
    ap.add_argument("--runs", default="/work/scratch/gen_runs", help="per-scene outputs, RUNS/<seed>/")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--manifest", default=MANIFEST)
    ap.add_argument("--out", default=OUT, help="results prefix (.md, .json, .png)")
    ap.add_argument("--binary", default=bench.DEFAULT_BIN)
    ap.add_argument("--mitsuba-python", default="/work/scratch/mi/bin/python")
    ap.add_argument("--relight", default="--bounces 2",
                    help="relight options (default: 2 indirect bounces, as the photos have; pixel integrated)")
    ap.add_argument("--seeds", help="comma-separated subset of the half's seeds (a partial run)")
    ap.add_argument("--allow-resample", action="store_true",
                    help="measure scenes re-drawn by a changed sampler (not comparable)")
    ap.add_argument("--report-only", action="store_true", help="rewrite the .md and .png from the .json, run nothing")
    a = ap.parse_args(argv)
    if a.report_only:
        doc = json.load(open(a.out + ".json"))
        doc["ceiling"] = CEILING
        write_markdown(doc, a.out + ".md")
        write_chart(doc, a.out + ".png")
        return

    manifest = load_manifest(a.manifest, a.allow_resample)
    halves = ["dev", "test"] if a.half == "all" else [a.half]
    if a.half in DRAWN_LATER:
        lo, hi = (int(x) for x in (a.extra_seeds or DEFAULT_SEEDS[a.half]).split("-"))
        if lo <= max(s["seed"] for s in manifest["scenes"]) or hi < lo:
            sys.exit("bench_generalization: --extra-seeds %s must lie above the frozen seeds" % a.extra_seeds)
        manifest["scenes"] += [{"seed": sd, "split": a.half, "params": mitsuba_scenes.draw_scene(sd)}
                               for sd in range(lo, hi + 1)]
    os.makedirs(a.runs, exist_ok=True)
    binary, sha = bench.snapshot_binary(a.binary, a.runs)
    json_path = a.out + ".json"
    doc = json.load(open(json_path)) if os.path.exists(json_path) else {"halves": {}}
    if doc.get("sampler_sha256") not in (None, manifest["sampler_sha256"]) and not a.allow_resample:
        doc["halves"] = {}  # results of another scene set
    doc.update(manifest=os.path.relpath(a.manifest, ROOT), frozen=manifest["frozen"],
               sampler_sha256=manifest["sampler_sha256"], split_rule=manifest["split_rule"],
               scene_count=len(manifest["scenes"]), ceiling=CEILING, relight_options=a.relight)
    wanted = {int(s) for s in a.seeds.split(",")} if a.seeds else None
    for half in halves:
        env = bench.environment(binary, sha)
        scenes = [s for s in manifest["scenes"] if s["split"] == half and (wanted is None or s["seed"] in wanted)]
        all_seeds = [s["seed"] for s in manifest["scenes"] if s["split"] == half]
        # A run of some seeds (--seeds) keeps the half's other rows; the JSON is written after every scene.
        old_rows = {r["seed"]: r for r in (doc["halves"].get(half) or {}).get("scenes", [])} if wanted else {}
        measured = {}

        def save():
            rows = [measured.get(sd) or old_rows.get(sd) for sd in all_seeds if measured.get(sd) or old_rows.get(sd)]
            doc["halves"][half] = {"env": env, "threads": a.threads, "reconstruct_extra": extra, "runs": a.runs,
                                   "cache": a.cache, "partial": len(rows) < len(all_seeds),
                                   "resampled_with": manifest.get("resampled_with"),
                                   "scenes": rows, "summary": summarize(rows)}
            json.dump(doc, open(json_path, "w"), indent=1)
        for scene in scenes:
            seed, p = scene["seed"], scene["params"]
            work = os.path.join(a.runs, str(seed))
            os.makedirs(work, exist_ok=True)
            log = os.path.join(work, "log.txt")
            open(log, "w").close()
            row = {"seed": seed, "true_count": p["true_count"], "true_families": [m["family"] for m in p["materials"]],
                   "scene": describe(p), "work": work}
            t0 = time.monotonic()
            row["loadavg_start"] = os.getloadavg()[0]
            try:
                cap, info = ensure_capture(scene, a.cache, a.mitsuba_python, a.allow_resample, log)
                row["render_s"] = info["render_s"]
                row["capture"] = cap
                row["ceiling_db"], row["ceiling_min_db"] = ceiling(cap, binary, log)
                row.update(measure(scene, cap, work, binary, a.threads, shlex.split(a.relight), extra))
            except bench.StepError as e:
                row["error"] = str(e)
            print("seed %2d %-28s %s  (%.0f s)" % (
                seed, row["scene"]["shape"][:28],
                row["error"][:100] if row.get("error") else "PSNR %.2f dB (ceiling %.2f), %d/%d materials, %.1f s, "
                "%.0f MB" % (row["psnr_db"], row["ceiling_db"], row["materials_chosen"], row["true_count"],
                             row["reconstruct_wall_s"], row["reconstruct_peak_rss_mb"] or 0),
                time.monotonic() - t0), flush=True)
            measured[seed] = row
            save()
    write_markdown(doc, a.out + ".md")
    write_chart(doc, a.out + ".png")
    print("wrote %s.{md,json,png}" % a.out)


if __name__ == "__main__":
    main()
