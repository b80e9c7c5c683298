#!/usr/bin/python3
"""End-to-end benchmark of the SVBRDF pipeline on one synthetic capture.

synth (timed) -> reconstruct (timed, peak RSS from /usr/bin/time -v and the
report's peak_memory_mb) -> relight the held-out views -> evaluate, then
compares the reconstruction with the ground truth:

  * cluster count and model labels chosen vs true,
  * diffuse albedo rd_r/g/b of every reconstructed basis material vs the
    ground-truth basis material its material_id texels overlap most
    (relative error),
  * adjusted Rand index of the reconstructed cluster map vs the true material
    ids over texels covered by both.

Writes bench_results/<preset>.json, .md (table + pass/fail of the issue's
targets) and .png (stage times + PSNR).

Usage: /usr/bin/python3 scripts/bench.py [--preset standard] [--out-dir /tmp/svbrdf_bench] [--skip-synth]
Run heavy jobs niced, e.g. `nice -n 5 /usr/bin/python3 scripts/bench.py`.
"""
import argparse
import datetime
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import html_report  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_BIN = os.path.join(ROOT, "build", "apps", "svbrdf")
RESULTS = os.path.join(ROOT, "bench_results")

# Targets of the benchmark issue.
TARGET_PSNR_DB = 40.0
TARGET_SECONDS = 60.0
TARGET_MEMORY_MB = 2048.0


# --------------------------------------------------------------------------- running the CLI

class StepError(RuntimeError):
    pass


def run(cmd, log_path, timed_rss=False):
    """Runs cmd, appends its output to log_path; returns (wall seconds, stdout, peak RSS MB or None)."""
    full = list(cmd)
    time_file = None
    if timed_rss and os.path.exists("/usr/bin/time"):
        time_file = log_path + ".time"
        full = ["/usr/bin/time", "-v", "-o", time_file] + full
    t0 = time.monotonic()
    try:
        p = subprocess.run(full, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    except OSError as e:  # e.g. the binary is missing or being relinked
        raise StepError(f"{' '.join(cmd[:2])}: cannot run: {e}")
    wall = time.monotonic() - t0
    with open(log_path, "a") as f:
        f.write("$ " + " ".join(cmd) + "\n")
        f.write(p.stdout)
        # Drop progress-bar lines from the log.
        f.write("".join(l + "\n" for l in p.stderr.splitlines() if "[#" not in l and "[-" not in l))
        f.write(f"# exit {p.returncode}, {wall:.2f} s\n\n")
    if p.returncode != 0:
        tail = [l for l in p.stderr.splitlines() if "[#" not in l][-5:]
        raise StepError(f"{cmd[1] if len(cmd) > 1 else cmd[0]} failed (exit {p.returncode}): " + " | ".join(tail))
    rss = None
    if time_file and os.path.exists(time_file):
        m = re.search(r"Maximum resident set size \(kbytes\):\s*(\d+)", open(time_file).read())
        if m:
            rss = int(m.group(1)) / 1024.0
    return wall, p.stdout, rss


def write_atomic(path, text):
    """Writes under a temporary name, then renames: a killed run leaves the previous results whole."""
    with open(path + ".tmp", "w") as f:
        f.write(text)
    os.replace(path + ".tmp", path)


def parse_evaluate(text):
    """Parses `svbrdf evaluate` output."""
    per_image = []
    for m in re.finditer(r"^(\S+)\s+PSNR\s+([-\d.inf]+) dB\s+rel\. RMSE\s+([-\d.einf]+)", text, re.M):
        per_image.append({"image": m.group(1), "psnr_db": float(m.group(2)), "rel_rmse": float(m.group(3))})
    m = re.search(r"mean PSNR ([-\d.inf]+) dB \(min ([-\d.inf]+)\), mean rel\. RMSE ([-\d.einf]+) over (\d+) images", text)
    if not m:
        raise StepError("cannot parse evaluate output: " + text[-300:])
    return {"psnr_mean_db": float(m.group(1)), "psnr_min_db": float(m.group(2)),
            "rel_rmse_mean": float(m.group(3)), "images": int(m.group(4)), "per_image": per_image}


def synth_cmd(binary, preset, out, extra=()):
    return [binary, "synth", "--preset", preset, "--out", out] + list(extra)


def pipeline(binary, capture, work, log, recon_extra=(), skip_synth=False, synth_args=None):
    """synth (unless skip_synth) + reconstruct + relight + evaluate. Returns a dict of raw results."""
    res = {}
    if not skip_synth:
        if os.path.exists(capture):
            shutil.rmtree(capture)
        res["synth_s"], _, _ = run(synth_args, log)
    elif not os.path.exists(os.path.join(capture, "scene.json")):
        raise StepError(f"--skip-synth but {capture}/scene.json does not exist")
    mat = os.path.join(work, "material")
    relit = os.path.join(work, "relit")
    for d in (mat, relit):
        if os.path.exists(d):
            shutil.rmtree(d)
    res["reconstruct_wall_s"], _, res["reconstruct_peak_rss_mb"] = run(
        [binary, "reconstruct", os.path.join(capture, "scene.json"), "--out", mat] + list(recon_extra), log,
        timed_rss=True)
    res["summary"] = json.load(open(os.path.join(mat, "report", "summary.json")))
    heldout = os.path.join(capture, "heldout", "scene.json")
    res["relight_s"], _, _ = run([binary, "relight", mat, heldout, "--out", relit], log)
    res["evaluate_s"], out, _ = run([binary, "evaluate", relit, heldout], log)
    res["evaluate"] = parse_evaluate(out)
    res["material_dir"] = mat
    return res


# --------------------------------------------------------------------------- ground-truth comparison

def read_image(path):
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise StepError(f"cannot read {path}: {oiio.geterror()}")
    spec = inp.spec()
    fmt = str(spec.format)
    if fmt in ("uint8", "uint16"):
        a = np.asarray(inp.read_image(fmt)).astype(np.int64)  # exact stored integers
    else:
        a = inp.read_image(oiio.FLOAT)
    inp.close()
    return np.asarray(a).reshape(spec.height, spec.width, spec.nchannels)


def resize_nearest(a, h, w):
    if a.shape[0] == h and a.shape[1] == w:
        return a
    ys = np.minimum(((np.arange(h) + 0.5) * a.shape[0] / h).astype(int), a.shape[0] - 1)
    xs = np.minimum(((np.arange(w) + 0.5) * a.shape[1] / w).astype(int), a.shape[1] - 1)
    return a[ys][:, xs]


def coverage(mat_dir, mat):
    """Texels the material defines: confidence > 0 if there is a confidence map, else weight sum > 0."""
    if mat.get("confidence"):
        c = read_image(os.path.join(mat_dir, mat["confidence"]))[..., 0]
        return c > 0
    s = None
    for w in mat["weights"]:
        a = read_image(os.path.join(mat_dir, w)).sum(axis=2)
        s = a if s is None else s + a
    return s > 0


def adjusted_rand_index(a, b):
    """ARI of two integer labelings (1-D arrays of equal length)."""
    a = np.unique(a, return_inverse=True)[1]
    b = np.unique(b, return_inverse=True)[1]
    n = a.size
    if n < 2:
        return float("nan")
    table = np.zeros((a.max() + 1, b.max() + 1), dtype=np.int64)
    np.add.at(table, (a, b), 1)
    comb = lambda x: (x * (x - 1) / 2.0).sum()
    sum_ij = comb(table.astype(float))
    sum_a = comb(table.sum(axis=1).astype(float))
    sum_b = comb(table.sum(axis=0).astype(float))
    expected = sum_a * sum_b / (n * (n - 1) / 2.0)
    maximum = 0.5 * (sum_a + sum_b)
    if maximum == expected:
        return 1.0
    return float((sum_ij - expected) / (maximum - expected))


def metal_f0(b):
    """F0 per channel of a basis material that is a metal: a conductor, or a
    metallic-roughness / principled material that is (nearly) all metal
    (metallic >= 0.95: its lobe is a Schlick conductor's, F0 = base colour
    mixed with the dielectric's F0); None otherwise."""
    p = b["params"]
    if b["model"] == "conductor":
        return conductor_f0(p)
    if b["model"] in ("gltf", "principled") and p.get("metallic", 0) >= 0.95:
        m = p["metallic"]
        if b["model"] == "gltf":
            f_diel = 0.04
        else:  # principled.h: eta = 2 / (1 - sqrt(0.08 specular)) - 1, F0 = ((eta - 1) / (eta + 1))^2
            eta = 2 / (1 - math.sqrt(0.08 * p["specular"])) - 1
            f_diel = ((eta - 1) / (eta + 1)) ** 2
        return [m * p["base_color_" + c] + (1 - m) * f_diel for c in "rgb"]
    return None


def conductor_f0(p):
    """F0 per channel of a conductor's parameters: ((eta-1)^2 + kappa^2) / ((eta+1)^2 + kappa^2), or f0_*."""
    if all(f"eta_{c}" in p and f"kappa_{c}" in p for c in "rgb"):
        return [((p[f"eta_{c}"] - 1) ** 2 + p[f"kappa_{c}"] ** 2) / ((p[f"eta_{c}"] + 1) ** 2 + p[f"kappa_{c}"] ** 2)
                for c in "rgb"]
    if all(f"f0_{c}" in p for c in "rgb"):
        return [p[f"f0_{c}"] for c in "rgb"]
    return None


def compare_with_gt(mat_dir, gt_dir):
    gt = json.load(open(os.path.join(gt_dir, "material.json")))
    rec = json.load(open(os.path.join(mat_dir, "material.json")))
    gid = read_image(os.path.join(gt_dir, gt["material_id"]))[..., 0]
    H, W = gid.shape
    gcov = coverage(gt_dir, gt) & (gid < len(gt["basis"]))
    out = {
        "true_clusters": len(gt["basis"]),
        "chosen_clusters": len(rec["basis"]),
        "true_labels": [b["label"] for b in gt["basis"]],
        "chosen_labels": [b["label"] for b in rec["basis"]],
        "gt_resolution": [W, H],
        "rec_resolution": rec.get("resolution"),
    }
    if not rec.get("material_id"):
        out["error"] = "reconstruction has no material_id map"
        return out
    rid = resize_nearest(read_image(os.path.join(mat_dir, rec["material_id"]))[..., 0], H, W)
    rcov = resize_nearest(coverage(mat_dir, rec), H, W) & (rid < len(rec["basis"]))
    both = gcov & rcov
    out["texels_gt"] = int(gcov.sum())
    out["texels_rec"] = int(rcov.sum())
    out["texels_both"] = int(both.sum())
    g, r = gid[both], rid[both]
    out["ari"] = adjusted_rand_index(g, r) if both.sum() > 1 else float("nan")
    matches = []
    for k, b in enumerate(rec["basis"]):
        counts = np.bincount(g[r == k], minlength=len(gt["basis"]))
        n = int(counts.sum())
        if n == 0:
            matches.append({"rec": k, "rec_name": b["name"], "rec_label": b["label"], "texels": 0, "gt": None})
            continue
        j = int(counts.argmax())
        gb = gt["basis"][j]
        rd = {}
        for c in ("rd_r", "rd_g", "rd_b"):
            t, e = gb["params"].get(c), b["params"].get(c)
            rd[c] = {"true": t, "est": e,
                     "rel_err": (abs(e - t) / abs(t) if t not in (None, 0) and e is not None else None)}
        errs = [v["rel_err"] for v in rd.values() if v["rel_err"] is not None]
        matches.append({
            "rec": k, "rec_name": b["name"], "rec_label": b["label"], "texels": n,
            "gt": j, "gt_name": gb["name"], "gt_label": gb["label"],
            "overlap_fraction": float(counts[j] / n),
            "label_match": b["label"] == gb["label"],
            "rd": rd,
            "rd_rel_err_mean": float(np.mean(errs)) if errs else None,
            "rd_rel_err_max": float(np.max(errs)) if errs else None,
        })
    out["matches"] = matches
    matched_gt = sorted({m["gt"] for m in matches if m["gt"] is not None})
    out["gt_basis_unmatched"] = [j for j in range(len(gt["basis"])) if j not in matched_gt]
    all_err = [m["rd_rel_err_max"] for m in matches if m.get("rd_rel_err_max") is not None]
    out["rd_rel_err_max"] = float(max(all_err)) if all_err else None
    mean_err = [m["rd_rel_err_mean"] for m in matches if m.get("rd_rel_err_mean") is not None]
    out["rd_rel_err_mean"] = float(np.mean(mean_err)) if mean_err else None
    # Metals: normal-incidence reflectance F0 per channel (from eta, kappa
    # or fitted f0) of each reconstructed conductor vs the true metal it maps to.
    metals = []
    for m in matches:
        if m["gt"] is None or gt["basis"][m["gt"]]["model"] != "conductor":
            continue
        f0_true = conductor_f0(gt["basis"][m["gt"]]["params"])
        b = rec["basis"][m["rec"]]
        f0_est = metal_f0(b)
        rel = ([abs(e - t) / t for e, t in zip(f0_est, f0_true)] if f0_est and f0_true else None)
        metals.append({"rec": m["rec"], "gt": m["gt"], "rec_label": b["label"], "conductor": f0_est is not None,
                       "f0_true": f0_true, "f0_est": f0_est, "f0_rel_err": rel,
                       "f0_rel_err_max": max(rel) if rel else None})
    out["metals"] = metals
    out["labels_right"] = (len(rec["basis"]) == len(gt["basis"]) and not out["gt_basis_unmatched"]
                           and all(m.get("label_match") for m in matches))
    return out


# --------------------------------------------------------------------------- environment

def snapshot_binary(binary, scratch):
    """Copies the CLI into the scratch folder so that a rebuild of the shared build tree during a long run
    cannot mix two versions of the code; returns (path of the copy, sha256 prefix)."""
    import hashlib
    if not os.path.exists(binary):
        raise StepError(f"{binary} does not exist; build first (scripts/setup.sh build)")
    sha = hashlib.sha256(open(binary, "rb").read()).hexdigest()[:12]
    d = os.path.join(scratch, "bin")
    os.makedirs(d, exist_ok=True)
    copy = os.path.join(d, f"svbrdf-{sha}")
    if not os.path.exists(copy):
        shutil.copy2(binary, copy + ".tmp")
        os.replace(copy + ".tmp", copy)
    return copy, sha


def environment(binary, sha=None):
    def git(*a):
        try:
            return subprocess.run(["git", "-C", ROOT] + list(a), stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                  text=True).stdout
        except OSError:
            return ""
    dirty = [l[3:] for l in git("status", "--porcelain", "--untracked-files=no").splitlines() if len(l) > 3]
    return {
        "date_utc": datetime.datetime.utcnow().strftime("%Y-%m-%dT%H:%M:%SZ"),
        "git_commit": git("rev-parse", "--short", "HEAD").strip(),
        "git_dirty_tracked_files": dirty,
        "binary": binary,
        "binary_sha256_12": sha,
        "binary_mtime_utc": datetime.datetime.utcfromtimestamp(os.path.getmtime(binary)).strftime(
            "%Y-%m-%dT%H:%M:%SZ") if os.path.exists(binary) else None,
        "cpus": os.cpu_count(),
        "machine": platform.machine(),
        "niceness": os.nice(0),
        "loadavg_start": os.getloadavg(),
    }


def env_note(env):
    s = (f"commit `{env['git_commit']}`, binary sha256 `{env.get('binary_sha256_12')}` "
         f"(built {env.get('binary_mtime_utc')}), {env['cpus']} CPUs ({env['machine']}), niceness {env['niceness']}, "
         f"load average at start {env['loadavg_start'][0]:.2f}, {env['date_utc']}")
    if env["git_dirty_tracked_files"]:
        s += ("; binary built from a working tree with uncommitted changes in: "
              + ", ".join(f"`{f}`" for f in env["git_dirty_tracked_files"]))
    return s


# --------------------------------------------------------------------------- main

def fmt(v, spec=".2f"):
    return "n/a" if v is None else format(v, spec)


def write_markdown(r, path):
    ev, sm, gt = r["evaluate"], r["summary"], r["gt"]
    L = [f"# Benchmark: `{r['preset']}` capture", "", env_note(r["environment"]), "",
         f"Capture: {r['capture_description']}", "",
         f"Reconstruct arguments: `{r.get('reconstruct_args') or '(defaults)'}`", "", "## Targets", "",
         "| target | measured | result |", "|---|---|---|"]
    for t in r["targets"]:
        L.append(f"| {t['name']} | {t['measured']} | {'PASS' if t['pass'] else '**FAIL**'} |")
    L += ["", "## Timings", "", "| stage | seconds |", "|---|---:|"]
    L.append(f"| synth (capture generation, not part of reconstruction) | {fmt(r.get('synth_s'))} |")
    for k, v in sm["timings_s"].items():
        L.append(f"| reconstruct: {k} | {v:.2f} |")
    L.append(f"| **reconstruct total (report total_s)** | **{sm['total_s']:.2f}** |")
    L.append(f"| reconstruct wall clock (process) | {r['reconstruct_wall_s']:.2f} |")
    L.append(f"| relight held-out ({ev['images']} views) | {r['relight_s']:.2f} |")
    L.append(f"| evaluate | {r['evaluate_s']:.2f} |")
    L += ["", "## Resources", "", "| quantity | value |", "|---|---:|",
          f"| peak memory (report peak_memory_mb) | {fmt(sm.get('peak_memory_mb'), '.0f')} MB |",
          f"| peak RSS (/usr/bin/time -v) | {fmt(r.get('reconstruct_peak_rss_mb'), '.0f')} MB |",
          f"| samples kept / candidates | {sm.get('samples', {}).get('kept', 'n/a')} / "
          f"{sm.get('samples', {}).get('candidates', 'n/a')} |",
          f"| texels | {sm.get('texels', 'n/a')} (texture {sm.get('texture_size', 'n/a')}) |"]
    L += ["", "## Held-out relighting", "",
          f"Mean PSNR (sRGB) **{ev['psnr_mean_db']:.2f} dB**, min {ev['psnr_min_db']:.2f} dB, "
          f"mean linear relative RMSE {ev['rel_rmse_mean']:.4f} over {ev['images']} held-out views.", "",
          "| view | PSNR (dB) | rel. RMSE |", "|---|---:|---:|"]
    for p in ev["per_image"]:
        L.append(f"| {p['image']} | {p['psnr_db']:.2f} | {p['rel_rmse']:.4f} |")
    L += ["", "## Material vs ground truth", "",
          f"Clusters chosen {gt['chosen_clusters']} vs true {gt['true_clusters']}; "
          f"labels chosen {gt['chosen_labels']} vs true {gt['true_labels']}.", "",
          f"Adjusted Rand index of the cluster map vs the true material ids: **{fmt(gt.get('ari'), '.4f')}** "
          f"over {gt.get('texels_both', 'n/a')} texels covered by both "
          f"(gt {gt.get('texels_gt', 'n/a')}, reconstruction {gt.get('texels_rec', 'n/a')}; "
          f"maps {gt['gt_resolution']} gt vs {gt['rec_resolution']} reconstruction, nearest resize).", "",
          "| reconstructed | label | matched gt | gt label | overlap | rd est (r,g,b) | rd true (r,g,b) | "
          "rd rel. err (r,g,b) |", "|---|---|---|---|---:|---|---|---|"]
    for m in gt.get("matches", []):
        if m["gt"] is None:
            L.append(f"| {m['rec_name']} | {m['rec_label']} | none (no texels) | | | | | |")
            continue
        rd = m["rd"]
        est = ", ".join(fmt(rd[c]["est"], ".3f") for c in ("rd_r", "rd_g", "rd_b"))
        tru = ", ".join(fmt(rd[c]["true"], ".3f") for c in ("rd_r", "rd_g", "rd_b"))
        err = ", ".join(fmt(None if rd[c]["rel_err"] is None else 100 * rd[c]["rel_err"], ".1f") + "%"
                        for c in ("rd_r", "rd_g", "rd_b"))
        L.append(f"| {m['rec_name']} | {m['rec_label']} | {m['gt_name']} | {m['gt_label']}"
                 f"{'' if m['label_match'] else ' (differs)'} | {100 * m['overlap_fraction']:.1f}% | {est} | {tru} | {err} |")
    if gt.get("gt_basis_unmatched"):
        L.append("")
        L.append(f"Ground-truth basis materials no reconstructed cluster maps to: {gt['gt_basis_unmatched']}.")
    L += ["", f"Mean rd relative error {fmt(None if gt.get('rd_rel_err_mean') is None else 100 * gt['rd_rel_err_mean'], '.2f')}%, "
              f"max {fmt(None if gt.get('rd_rel_err_max') is None else 100 * gt['rd_rel_err_max'], '.2f')}%.", "",
          "Produced by `scripts/bench.py`; raw numbers in the .json next to this file."]
    open(path, "w").write("\n".join(L) + "\n")


def write_chart(r, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    sm, ev = r["summary"], r["evaluate"]
    names, vals = [], []
    if r.get("synth_s") is not None:
        names.append("synth")
        vals.append(r["synth_s"])
    for k, v in sm["timings_s"].items():
        names.append("rec: " + k)
        vals.append(v)
    names += ["relight", "evaluate"]
    vals += [r["relight_s"], r["evaluate_s"]]
    fig, ax = plt.subplots(figsize=(9, 5))
    bars = ax.barh(names[::-1], vals[::-1], color="tab:blue")
    for b, v in zip(bars, vals[::-1]):
        ax.text(b.get_width(), b.get_y() + b.get_height() / 2, f" {v:.2f} s", va="center", fontsize=8)
    ax.set_xlabel("seconds (wall)")
    ax.set_xlim(0, max(vals) * 1.3 + 1e-9)
    gt = r["gt"]
    ax.set_title(f"svbrdf benchmark, '{r['preset']}' capture: reconstruction {sm['total_s']:.1f} s, "
                 f"peak {sm.get('peak_memory_mb', 0):.0f} MB")
    txt = (f"held-out PSNR mean {ev['psnr_mean_db']:.2f} dB (min {ev['psnr_min_db']:.2f})\n"
           f"rel. RMSE {ev['rel_rmse_mean']:.4f}\n"
           f"clusters {gt['chosen_clusters']} (true {gt['true_clusters']}), ARI {fmt(gt.get('ari'), '.3f')}")
    ax.text(0.98, 0.04, txt, transform=ax.transAxes, ha="right", va="bottom", fontsize=9,
            bbox=dict(boxstyle="round", fc="white", ec="0.6"))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def targets(r):
    sm, ev, gt = r["summary"], r["evaluate"], r["gt"]
    target_psnr = r.get("target_psnr_db", TARGET_PSNR_DB)
    mem = sm.get("peak_memory_mb")
    if r.get("reconstruct_peak_rss_mb") is not None:
        mem = max(mem or 0, r["reconstruct_peak_rss_mb"])
    t_rec = max(sm["total_s"], r["reconstruct_wall_s"])
    return [
        {"name": f"held-out PSNR >= {target_psnr:g} dB (mean)", "measured": f"{ev['psnr_mean_db']:.2f} dB "
         f"(min {ev['psnr_min_db']:.2f})", "pass": ev["psnr_mean_db"] >= target_psnr},
        {"name": "basis material count right", "measured": f"{gt['chosen_clusters']} chosen, "
         f"{gt['true_clusters']} true", "pass": gt["chosen_clusters"] == gt["true_clusters"]},
        {"name": f"reconstruction < {TARGET_SECONDS:.0f} s", "measured": f"{t_rec:.1f} s "
         f"(wall, {os.cpu_count()} CPUs, shared machine)", "pass": t_rec < TARGET_SECONDS},
        {"name": f"peak memory < {TARGET_MEMORY_MB / 1024:.0f} GB", "measured": f"{mem:.0f} MB",
         "pass": mem is not None and mem < TARGET_MEMORY_MB},
    ] + [
        {"name": f"metal {m['gt']} recognised as a metal, F0 within 5 %",
         "measured": (f"{m['rec_label']}, F0 " + ", ".join(f"{e:.4f}" for e in m["f0_est"]) + " vs true "
                      + ", ".join(f"{t:.4f}" for t in m["f0_true"]) + f" (max {100 * m['f0_rel_err_max']:.1f} %)")
         if m["f0_est"] else f"{m['rec_label']} (not a metal)",
         "pass": bool(m["f0_est"]) and m["f0_rel_err_max"] <= 0.05}
        for m in gt.get("metals", [])
    ] + [
        {"name": "(info) model labels right", "measured": f"{gt['chosen_labels']} vs {gt['true_labels']}",
         "pass": bool(gt.get("labels_right"))},
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="standard")
    ap.add_argument("--out-dir", default="/tmp/svbrdf_bench", help="scratch folder")
    ap.add_argument("--skip-synth", action="store_true", help="reuse OUT_DIR/<preset>/capture")
    ap.add_argument("--bin", default=DEFAULT_BIN, help="svbrdf binary")
    ap.add_argument("--results", default=RESULTS, help="results folder")
    ap.add_argument("--reconstruct-args", default="", help="extra reconstruct arguments (quoted)")
    ap.add_argument("--target-psnr", type=float, default=TARGET_PSNR_DB, help="held-out PSNR target (dB)")
    ap.add_argument("--name", default=None, help="basename of the result files (default: the preset)")
    a = ap.parse_args()

    work = os.path.join(os.path.abspath(a.out_dir), a.preset)
    capture = os.path.join(work, "capture")
    os.makedirs(work, exist_ok=True)
    os.makedirs(a.results, exist_ok=True)
    log = os.path.join(work, "bench.log")
    open(log, "w").close()
    binary, sha = snapshot_binary(a.bin, os.path.abspath(a.out_dir))
    r = {"preset": a.preset, "environment": environment(a.bin, sha), "log": log, "target_psnr_db": a.target_psnr,
         "reconstruct_args": a.reconstruct_args}
    preset_file = os.path.join(ROOT, "datasets_synth", a.preset + ".json")
    r["capture_description"] = (json.load(open(preset_file)).get("description", a.preset)
                                if os.path.exists(preset_file) else a.preset)
    print(f"[bench] preset {a.preset}, scratch {work}, log {log}", flush=True)
    r.update(pipeline(binary, capture, work, log, recon_extra=a.reconstruct_args.split(),
                      skip_synth=a.skip_synth, synth_args=synth_cmd(binary, a.preset, capture)))
    if a.skip_synth:
        r["synth_s"] = None
    r["gt"] = compare_with_gt(r["material_dir"], os.path.join(capture, "gt"))
    r["targets"] = targets(r)
    base = os.path.join(a.results, a.name or a.preset)
    json.dump(r, open(base + ".json", "w"), indent=2)
    write_markdown(r, base + ".md")
    write_chart(r, base + ".png")
    html_report.write_html(base + ".html", f"svbrdf benchmark: {a.preset} capture", [base + ".md"], [base + ".png"])
    ev, sm, gt = r["evaluate"], r["summary"], r["gt"]
    print(f"[bench] reconstruction {sm['total_s']:.1f} s, peak {sm.get('peak_memory_mb', 0):.0f} MB, "
          f"held-out PSNR {ev['psnr_mean_db']:.2f} dB (min {ev['psnr_min_db']:.2f}), rel RMSE {ev['rel_rmse_mean']:.4f}, "
          f"clusters {gt['chosen_clusters']}/{gt['true_clusters']}, ARI {fmt(gt.get('ari'), '.3f')}")
    for t in r["targets"]:
        print(f"[bench]   {'PASS' if t['pass'] else 'FAIL'}  {t['name']}: {t['measured']}")
    print(f"[bench] wrote {base}.json, {base}.md, {base}.png, {base}.html")


if __name__ == "__main__":
    try:
        main()
    except StepError as e:
        sys.exit(f"[bench] error: {e}")
