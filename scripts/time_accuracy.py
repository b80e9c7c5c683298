#!/usr/bin/python3
"""Time-accuracy chart: held-out PSNR of `reconstruct --time-budget B` over budgets.

For each budget: reconstruct (wall and CPU time from /usr/bin/time -v) ->
relight the capture's held-out views -> evaluate. One run without a budget is
the reference. Writes OUT.json, OUT.md and OUT.png.

Usage:
  scripts/time_accuracy.py --replot [--out bench_results/time_accuracy]   (md and png from the json)
  scripts/time_accuracy.py --capture CAP [--capture CAP2 ...] [--budgets 2,5,10,20,40,80,120]
                           [--out bench_results/time_accuracy] [--binary build/apps/svbrdf]
                           [--relight-arg=--bounces --relight-arg=2]
CAP is a capture folder with scene.json and heldout/scene.json (svbrdf synth --preset standard --out CAP).
A capture is named by its folder, or by its parent folder when the folder is called "capture".
Captures rendered with interreflection (Mitsuba's) are relit with `--relight-arg=--bounces --relight-arg=2`.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def timed(cmd):
    """Runs cmd under /usr/bin/time -v; returns (stdout+stderr, wall s, cpu s, peak MB)."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as t:
        p = subprocess.run(["/usr/bin/time", "-v", "-o", t.name] + cmd, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)
        tv = open(t.name).read()
    if p.returncode != 0:
        sys.exit("failed (%d): %s\n%s" % (p.returncode, " ".join(cmd), p.stdout[-2000:]))
    g = lambda k: re.search(re.escape(k) + r":\s*(\S+)", tv).group(1)
    wall = sum(float(x) * 60 ** i for i, x in enumerate(reversed(g("Elapsed (wall clock) time (h:mm:ss or m:ss)").split(":"))))
    cpu = float(g("User time (seconds)")) + float(g("System time (seconds)"))
    return p.stdout, wall, cpu, int(g("Maximum resident set size (kbytes)")) / 1024.0


def capture_name(cap):
    """The capture's folder name, or its parent's when the folder is just "capture"."""
    path = os.path.abspath(cap.rstrip("/"))
    name = os.path.basename(path)
    return os.path.basename(os.path.dirname(path)) if name == "capture" else name


def psnr(binary, mat, heldout, work, relight_args=()):
    relit = os.path.join(work, "relit")
    shutil.rmtree(relit, ignore_errors=True)
    subprocess.run([binary, "relight", mat, heldout, "--out", relit] + list(relight_args), check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    out = subprocess.run([binary, "evaluate", relit, heldout], check=True, stdout=subprocess.PIPE, text=True).stdout
    m = re.search(r"mean PSNR ([\d.]+) dB \(min ([\d.]+)\)", out)
    return float(m.group(1)), float(m.group(2))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--capture", action="append")
    ap.add_argument("--replot", action="store_true", help="only rewrite OUT.md and OUT.png from OUT.json")
    ap.add_argument("--budgets", default="2,5,10,20,40,80,120")
    ap.add_argument("--out", default=os.path.join(ROOT, "bench_results", "time_accuracy"))
    ap.add_argument("--binary", default=os.path.join(ROOT, "build", "apps", "svbrdf"))
    ap.add_argument("--relight-arg", action="append", default=[],
                    help="passed on to `svbrdf relight` (repeat: --relight-arg=--bounces --relight-arg=2)")
    a = ap.parse_args()
    if a.replot:
        results = json.load(open(a.out + ".json"))
        write_md_png(results, a.out)
        return
    if not a.capture:
        ap.error("--capture is required (or --replot)")
    budgets = [float(b) for b in a.budgets.split(",")]
    load = os.getloadavg()
    results = {"budgets_s": budgets, "nproc": os.cpu_count(), "load_average_at_start": load[0],
               "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "captures": []}
    work = tempfile.mkdtemp(prefix="svbrdf_time_accuracy_")
    for cap in a.capture:
        scene, heldout = os.path.join(cap, "scene.json"), os.path.join(cap, "heldout", "scene.json")
        runs = []
        for b in budgets + [0.0]:
            mat = os.path.join(work, "mat")
            shutil.rmtree(mat, ignore_errors=True)
            cmd = [a.binary, "reconstruct", scene, "--out", mat, "--no-report"]
            if b > 0:
                cmd += ["--time-budget", str(b)]
            log, wall, cpu, peak = timed(cmd)
            k = re.search(r"\((\d+) basis materials\)", log)
            mean, low = psnr(a.binary, mat, heldout, work, a.relight_arg)
            r = {"budget_s": b, "wall_s": wall, "cpu_s": cpu, "peak_mb": peak, "clusters": int(k.group(1)),
                 "load_1min_after": os.getloadavg()[0],
                 "psnr_mean_db": mean, "psnr_min_db": low}
            print(capture_name(cap), r, flush=True)
            runs.append(r)
        results["captures"].append({"capture": capture_name(cap), "runs": runs})
    results["relight_args"] = a.relight_arg
    shutil.rmtree(work, ignore_errors=True)
    json.dump(results, open(a.out + ".json", "w"), indent=2)
    write_md_png(results, a.out)


def write_md_png(results, out):
    load = [results["load_average_at_start"]]
    L = ["# Time-accuracy: `reconstruct --time-budget`", "",
         "Held-out PSNR (sRGB, mean over the capture's held-out views) of the material returned within each "
         "budget; budget 0 = no budget (reference). Wall and CPU time of the whole `reconstruct` process "
         "(`/usr/bin/time -v`). %d CPUs, shared with other work: load average %.1f at the start, so wall "
         "times are inflated; the budget is wall time, so under load a budget buys less work than on an idle "
         "machine. Held-out views relit with `svbrdf relight`'s default (each pixel integrated until converged, "
         "since stop 21; before, the pixel centre)%s. Produced by `scripts/time_accuracy.py` on %s."
         % (results["nproc"], load[0],
            " with `%s`" % " ".join(results["relight_args"]) if results.get("relight_args") else "",
            results["date"]), ""]
    for c in results["captures"]:
        L += ["## %s" % c["capture"], "", "| budget (s) | wall (s) | CPU (s) | load (1 min, after) | clusters | PSNR mean (dB) | PSNR min (dB) |",
              "|---:|---:|---:|---:|---:|---:|---:|"]
        for r in c["runs"]:
            L.append("| %s | %.1f | %.1f | %.1f | %d | %.2f | %.2f |" % (
                "none" if r["budget_s"] == 0 else "%g" % r["budget_s"], r["wall_s"], r["cpu_s"], r.get("load_1min_after", 0),
                r["clusters"], r["psnr_mean_db"], r["psnr_min_db"]))
        L.append("")
    open(out + ".md", "w").write("\n".join(L) + "\n")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for c in results["captures"]:
        runs = [r for r in c["runs"] if r["budget_s"] > 0]
        line, = ax.plot([r["budget_s"] for r in runs], [r["psnr_mean_db"] for r in runs], "o-", label=c["capture"])
        ref = [r for r in c["runs"] if r["budget_s"] == 0][0]
        ax.axhline(ref["psnr_mean_db"], color=line.get_color(), ls=":", lw=1)
        ax.plot([ref["wall_s"]], [ref["psnr_mean_db"]], "*", color=line.get_color(), ms=11,
                label="%s, no budget (%.0f s wall)" % (c["capture"], ref["wall_s"]))
    ax.set_xscale("log")
    ax.set_xlabel("time budget (s, wall; machine shared, load %.1f)" % load[0])
    ax.set_ylabel("held-out PSNR (dB)")
    ax.set_title("Anytime reconstruction: accuracy over time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out + ".png", dpi=110)
    print("wrote", out + ".{json,md,png}")


if __name__ == "__main__":
    main()
