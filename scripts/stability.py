#!/usr/bin/python3
"""Stability study: how held-out relighting quality, the chosen cluster count
and the reconstruction time react to capture faults, one fault at a time, on
a small synthetic capture (preset "default"; every other setting as in the
preset, so the preset itself is the zero point of pose/light/geometry errors
and the 24-photo point).

For every point: synth, reconstruct, relight the held-out views, evaluate.
Also an accuracy-vs-time sweep of reconstruct --max-fit-samples on the
unfaulted capture.

Writes bench_results/stability.{json,md,png} and
bench_results/speed_accuracy.{md,png}.

Each point's result is cached in OUT_DIR/stability/<point>/result.json and
reused by later runs with the same binary (so a full run after --quick only
adds the missing points); --fresh recomputes everything. The CLI is copied
into OUT_DIR/bin at start, so a rebuild of the shared build tree mid-run
cannot mix two versions of the code.

Usage: nice -n 5 /usr/bin/python3 scripts/stability.py [--quick] [--preset default] [--out-dir /tmp/svbrdf_bench]
       [--faults images,noise] [--name stability_images]   (a subset of the faults, into its own files)
"""
import argparse
import json
import os
import shutil
import sys
import time
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench  # noqa: E402
import html_report  # noqa: E402

# fault -> (synth flag, full values, quick values, unit)
FAULTS = {
    "noise": ("--noise", [0, 0.005, 0.01, 0.02], [0, 0.02], "shot-noise factor"),
    "images": ("--images", [8, 12, 16, 24], [8, 24], "photos"),
    "pose_error_deg": ("--pose-error-deg", [0, 0.25, 0.5, 1.0], [0, 1.0], "degrees"),
    "light_error_mm": ("--light-error-mm", [0, 10, 25, 50], [0, 50], "mm"),
    "geometry_noise_mm": ("--geometry-noise-mm", [0, 1, 2], [0, 2], "mm"),
}
FIT_SAMPLES = {"full": [2000, 5000, 10000, 20000], "quick": [2000, 5000]}


def preset_values(preset):
    p = json.load(open(os.path.join(bench.ROOT, "datasets_synth", preset + ".json")))
    return {"noise": p.get("noise", 0.0), "images": p.get("num_images", 16), "pose_error_deg": 0.0,
            "light_error_mm": 0.0, "geometry_noise_mm": 0.0}


def point_key(fault, value, base):
    """Points equal to the preset share one run (key 'baseline')."""
    if float(value) == float(base[fault]):
        return "baseline"
    return f"{fault}={value:g}"


def run_point(binary, preset, work, key, synth_extra, recon_extra, fresh, capture=None):
    """synth (unless `capture` given) + reconstruct + relight + evaluate, cached in work/key/result.json."""
    d = os.path.join(work, key)
    cache = os.path.join(d, "result.json")
    if not fresh and os.path.exists(cache):
        r = json.load(open(cache))
        if r.get("binary") == os.path.basename(binary):  # same code: reuse
            r["cached"] = True
            print(f"[stability] {key}: cached ({r.get('status')})", flush=True)
            return r
    if os.path.exists(d):
        shutil.rmtree(d)
    os.makedirs(d)
    log = os.path.join(d, "run.log")
    open(log, "w").close()
    r = {"key": key, "synth_args": list(synth_extra), "reconstruct_args": list(recon_extra),
         "started": time.strftime("%Y-%m-%dT%H:%M:%S"), "binary": os.path.basename(binary)}
    print(f"[stability] {key}: running ...", flush=True)
    try:
        cap = capture or os.path.join(d, "capture")
        raw = bench.pipeline(binary, cap, d, log, recon_extra=recon_extra, skip_synth=capture is not None,
                             synth_args=bench.synth_cmd(binary, preset, cap, synth_extra))
        sm, ev = raw["summary"], raw["evaluate"]
        r.update({
            "status": "ok",
            "synth_s": raw.get("synth_s"),
            "reconstruct_s": sm["total_s"],
            "reconstruct_wall_s": raw["reconstruct_wall_s"],
            "peak_memory_mb": sm.get("peak_memory_mb"),
            "clusters": sm.get("clusters", len(sm.get("basis", []))),
            "labels": [b["label"] for b in sm.get("basis", [])],
            "psnr_mean_db": ev["psnr_mean_db"], "psnr_min_db": ev["psnr_min_db"],
            "rel_rmse_mean": ev["rel_rmse_mean"], "heldout_images": ev["images"],
            "samples_kept": sm.get("samples", {}).get("kept"),
        })
        gt_dir = os.path.join(cap, "gt")
        try:
            g = bench.compare_with_gt(raw["material_dir"], gt_dir)
            r.update({"true_clusters": g["true_clusters"], "ari": g.get("ari"),
                      "rd_rel_err_max": g.get("rd_rel_err_max")})
        except Exception as e:  # comparison is secondary; keep the point
            r["gt_compare_error"] = str(e)
        # Keep the scratch small: drop relit images (the material stays for inspection).
        shutil.rmtree(os.path.join(d, "relit"), ignore_errors=True)
    except bench.StepError as e:
        r.update({"status": "failed", "error": str(e)})
    except Exception as e:
        r.update({"status": "failed", "error": f"{type(e).__name__}: {e}", "trace": traceback.format_exc()})
    r["log"] = log
    json.dump(r, open(cache, "w"), indent=2)
    if r["status"] == "ok":
        print(f"[stability] {key}: PSNR {r['psnr_mean_db']:.2f} dB (min {r['psnr_min_db']:.2f}), "
              f"{r['clusters']} clusters, reconstruct {r['reconstruct_s']:.1f} s", flush=True)
    else:
        print(f"[stability] {key}: FAILED: {r['error']}", flush=True)
    return r


def f2(v, spec=".2f"):
    return "n/a" if v is None else format(v, spec)


def write_stability_md(study, path):
    L = ["# Stability study", "", bench.env_note(study["environment"]), "",
         f"Capture: preset `{study['preset']}` ({study['description']}). One fault varied at a time, everything "
         f"else as in the preset (noise {study['base']['noise']:g}, {study['base']['images']} photos, no pose/light/"
         f"geometry error); held-out PSNR is the mean (min) over the capture's held-out views, sRGB. "
         f"True basis material count: {study.get('true_clusters', 'n/a')}. "
         f"Mode: {'quick' if study['quick'] else 'full'}.", "",
         "| fault | value | held-out PSNR mean (min) dB | rel. RMSE | clusters | models | ARI | "
         "reconstruct s | run |", "|---|---:|---|---:|---:|---|---:|---:|---|"]
    for f, pts in study["faults"].items():
        for p in pts:
            r = p["result"]
            if r["status"] != "ok":
                L.append(f"| {f} | {p['value']:g} | **failed**: {r['error'][:160]} | | | | | | {p['key']} |")
                continue
            L.append(f"| {f} | {p['value']:g} | {r['psnr_mean_db']:.2f} ({r['psnr_min_db']:.2f}) | "
                     f"{r['rel_rmse_mean']:.4f} | {r['clusters']} | {', '.join(r['labels'])} | "
                     f"{f2(r.get('ari'), '.3f')} | {r['reconstruct_s']:.1f} | {p['key']} |")
    L += ["", "Rows with run `baseline` are one and the same reconstruction (the unfaulted preset). "
              "Reconstruction times are wall-clock on a shared 2-core machine and vary by a few seconds between runs.",
          "", "Produced by `scripts/stability.py`; raw numbers in stability.json."]
    open(path, "w").write("\n".join(L) + "\n")


def write_stability_png(study, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(study["faults"])
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5))
    axes = axes.ravel()
    for ax, f in zip(axes, names):
        pts = [p for p in study["faults"][f] if p["result"]["status"] == "ok"]
        bad = [p for p in study["faults"][f] if p["result"]["status"] != "ok"]
        xs = [p["value"] for p in pts]
        ax.plot(xs, [p["result"]["psnr_mean_db"] for p in pts], "o-", label="mean")
        ax.plot(xs, [p["result"]["psnr_min_db"] for p in pts], "s--", alpha=0.6, label="min")
        for p in pts:
            ax.annotate(f"K={p['result']['clusters']}", (p["value"], p["result"]["psnr_mean_db"]),
                        textcoords="offset points", xytext=(0, 7), ha="center", fontsize=8)
        for p in bad:
            ax.axvline(p["value"], color="r", ls=":", alpha=0.7)
            ax.text(p["value"], 0.02, " failed", color="r", transform=ax.get_xaxis_transform(), fontsize=8)
        ax.axhline(bench.TARGET_PSNR_DB, color="g", ls=":", lw=1)
        ax.set_xlabel(f"{f} ({FAULTS[f][3]})")
        ax.set_ylabel("held-out PSNR (dB)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower left")
    # Last panel: reconstruction time per point.
    ax = axes[len(names)]
    labels, secs = [], []
    for f in names:
        for p in study["faults"][f]:
            if p["result"]["status"] == "ok" and p["key"] not in labels:
                labels.append(p["key"])
                secs.append(p["result"]["reconstruct_s"])
    ax.barh(labels[::-1], secs[::-1], color="tab:gray")
    ax.set_xlabel("reconstruction seconds")
    ax.tick_params(axis="y", labelsize=7)
    for ax in axes[len(names) + 1:]:
        ax.axis("off")
    fig.suptitle(f"Stability on preset '{study['preset']}' (K = chosen basis materials, true "
                 f"{study.get('true_clusters', '?')}; green: 40 dB target)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_speed(sweep, env, quick, path_md, path_png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    L = ["# Accuracy vs reconstruction time", "", bench.env_note(env), "",
         "`svbrdf reconstruct --max-fit-samples N` on the unfaulted `default` capture (same capture for every N); "
         f"mode {'quick' if quick else 'full'}.", "",
         "| max fit samples | reconstruct s | held-out PSNR mean (min) dB | rel. RMSE | clusters | models |",
         "|---:|---:|---|---:|---:|---|"]
    ok = []
    for n, r in sweep:
        if r["status"] != "ok":
            L.append(f"| {n} | failed: {r['error'][:160]} | | | | |")
            continue
        ok.append((n, r))
        L.append(f"| {n} | {r['reconstruct_s']:.1f} | {r['psnr_mean_db']:.2f} ({r['psnr_min_db']:.2f}) | "
                 f"{r['rel_rmse_mean']:.4f} | {r['clusters']} | {', '.join(r['labels'])} |")
    L += ["", "Produced by `scripts/stability.py`."]
    open(path_md, "w").write("\n".join(L) + "\n")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.plot([r["reconstruct_s"] for _, r in ok], [r["psnr_mean_db"] for _, r in ok], "o-")
    for n, r in ok:
        ax.annotate(f"{n} (K={r['clusters']})", (r["reconstruct_s"], r["psnr_mean_db"]),
                    textcoords="offset points", xytext=(5, 5), fontsize=8)
    ax.set_xlabel("reconstruction seconds (wall)")
    ax.set_ylabel("held-out PSNR mean (dB)")
    ax.set_title("accuracy vs time: --max-fit-samples sweep")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path_png, dpi=100)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="default")
    ap.add_argument("--out-dir", default="/tmp/svbrdf_bench", help="scratch folder")
    ap.add_argument("--quick", action="store_true", help="fewer points (2 per fault, 2 sample counts)")
    ap.add_argument("--fresh", action="store_true", help="ignore cached points")
    ap.add_argument("--skip-speed", action="store_true", help="skip the --max-fit-samples sweep")
    ap.add_argument("--bin", default=bench.DEFAULT_BIN)
    ap.add_argument("--results", default=bench.RESULTS)
    ap.add_argument("--faults", default=",".join(FAULTS), help="comma-separated faults to vary (default: all)")
    ap.add_argument("--name", default="stability", help="basename of the result files in --results")
    a = ap.parse_args()
    faults = [f for f in a.faults.split(",") if f]
    for f in faults:
        if f not in FAULTS:
            sys.exit(f"stability: unknown fault '{f}' (known: {', '.join(FAULTS)})")

    work = os.path.join(os.path.abspath(a.out_dir), "stability", a.preset)
    os.makedirs(work, exist_ok=True)
    os.makedirs(a.results, exist_ok=True)
    binary, sha = bench.snapshot_binary(a.bin, os.path.abspath(a.out_dir))
    env = bench.environment(a.bin, sha)
    base = preset_values(a.preset)
    desc = json.load(open(os.path.join(bench.ROOT, "datasets_synth", a.preset + ".json"))).get("description", "")
    study = {"preset": a.preset, "description": desc, "quick": a.quick, "base": base, "environment": env,
             "faults": {}}
    results = {}
    out = os.path.join(a.results, a.name)
    for f, (flag, full, quick, _unit) in FAULTS.items():
        if f not in faults:
            continue
        pts = []
        for v in (quick if a.quick else full):
            key = point_key(f, v, base)
            if key not in results:
                extra = [] if key == "baseline" else [flag, f"{v:g}"]
                results[key] = run_point(binary, a.preset, work, key, extra, [], a.fresh)
            pts.append({"value": v, "key": key, "result": results[key]})
        study["faults"][f] = pts
        # Write after every fault so partial studies survive interruption.
        json.dump(study, open(out + ".json", "w"), indent=2)
    trues = {r.get("true_clusters") for r in results.values() if r.get("true_clusters")}
    study["true_clusters"] = trues.pop() if len(trues) == 1 else sorted(trues)
    json.dump(study, open(out + ".json", "w"), indent=2)
    write_stability_md(study, out + ".md")
    write_stability_png(study, out + ".png")
    html_report.write_html(out + ".html", "svbrdf stability study", [out + ".md"], [out + ".png"])
    print(f"[stability] wrote {out}.json, .md, .png", flush=True)

    if a.skip_speed:
        return
    baseline_capture = os.path.join(work, "baseline", "capture")
    sweep = []
    for n in FIT_SAMPLES["quick" if a.quick else "full"]:
        r = run_point(binary, a.preset, work, f"fit_samples={n}", [], ["--max-fit-samples", str(n)], a.fresh,
                      capture=baseline_capture)
        sweep.append((n, r))
    json.dump({"preset": a.preset, "environment": env, "quick": a.quick,
               "sweep": [{"max_fit_samples": n, **r} for n, r in sweep]},
              open(os.path.join(a.results, "speed_accuracy.json"), "w"), indent=2)
    write_speed(sweep, env, a.quick, os.path.join(a.results, "speed_accuracy.md"),
                os.path.join(a.results, "speed_accuracy.png"))
    html_report.write_html(os.path.join(a.results, "speed_accuracy.html"), "svbrdf speed vs accuracy",
                           [os.path.join(a.results, "speed_accuracy.md")], [os.path.join(a.results, "speed_accuracy.png")])
    print(f"[stability] wrote {a.results}/speed_accuracy.md, speed_accuracy.png (+ .json)", flush=True)


if __name__ == "__main__":
    main()
