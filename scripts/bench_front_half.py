#!/usr/bin/python3
"""The front half (calibrate, capture) measured on raw sets rendered by
another renderer (scripts/mitsuba_raw_set.py; issue 25), then a quick pass of
the back half (reconstruct, relight, evaluate) on the capture it made.

For every raw set DIR (capture.json + truth/truth.json):
  calibrate    svbrdf calibrate on the calibration photos: focal error (%),
               principal point error (px), board poses of the calibration
               photos (camera centres mm, rotations deg)
  capture      svbrdf capture DIR: the same for the object photos' poses, the
               registered mesh's RMS vertex distance from its true placement
               (mm; the rough placement's for reference), the lamp's position
               (mm) and intensity, GrabCut masks' IoU with the true
               silhouettes (truth/masks)
  reconstruct  svbrdf reconstruct (small and fast options)
  relight      svbrdf relight + svbrdf evaluate on the capture's own photos
A stage that fails is recorded with its error text; later stages that need
it are skipped.

The lamp intensity: `capture` measures it on the board's white paper of
known albedo. When capture.json gives no white_albedo the capture's albedo
assumption is unknown here, so the ratio estimate / truth is reported as a
scale (its error is only a % error when the albedo was given).

Usage:
  scripts/bench_front_half.py /work/scratch/raw_sets/* --out bench_results/front_half_mitsuba.json
(writes the .md next to the .json; work folders under --work).
"""
import argparse
import datetime
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench import DEFAULT_BIN, StepError, parse_evaluate, run  # noqa: E402  (the project's CLI runner)

LIMITS = {"centre_median_mm": 2.0, "rotation_median_deg": 0.2, "mesh_rms_mm": 1.0, "lamp_mm": 10.0,
          "focal_pct": 0.5}


def qmat(q):
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def pose(p):
    return qmat(p["q"]), np.asarray(p["t"], float)


def pose_errors(pairs):
    """[(estimated, true) cam_from_world] -> centre errors (mm), rotation errors (deg)."""
    c_mm, r_deg = [], []
    for est, tru in pairs:
        re_, te = pose(est)
        rt, tt = pose(tru)
        c_mm.append(1e3 * np.linalg.norm(-re_.T @ te - (-rt.T @ tt)))
        cos = (np.trace(re_ @ rt.T) - 1) / 2
        r_deg.append(math.degrees(math.acos(max(-1.0, min(1.0, cos)))))
    return np.array(c_mm), np.array(r_deg)


def summarise(prefix, c_mm, r_deg):
    if len(c_mm) == 0:
        return {prefix + "posed": 0}
    return {prefix + "centre_median_mm": float(np.median(c_mm)), prefix + "centre_worst_mm": float(c_mm.max()),
            prefix + "rotation_median_deg": float(np.median(r_deg)), prefix + "rotation_worst_deg": float(r_deg.max())}


def intrinsics_errors(params, model, truth_cam):
    fx, fy, cx, cy = truth_cam["params"][:4]
    if model in ("SIMPLE_PINHOLE", "SIMPLE_RADIAL", "RADIAL"):
        f_e, cx_e, cy_e = params[0], params[1], params[2]
        fx_e = fy_e = f_e
    else:
        fx_e, fy_e, cx_e, cy_e = params[:4]
    return {"model": model, "params": params,
            "focal_error_pct": float(100 * (0.5 * (fx_e + fy_e) / (0.5 * (fx + fy)) - 1)),
            "principal_point_error_px": float(math.hypot(cx_e - cx, cy_e - cy))}


def read_obj_vertices(path):
    return np.array([[float(x) for x in l.split()[1:4]] for l in open(path) if l.startswith("v ")])


def read_mask(path):
    import cv2
    m = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if m is None:
        raise FileNotFoundError(path)
    if m.ndim == 3:
        m = m[:, :, 0]
    return m > (m.max() / 2 if m.max() > 0 else 0)


def bench_set(raw, work, binary, threads, log, front_only=False):
    name = os.path.basename(raw.rstrip("/"))
    truth = json.load(open(os.path.join(raw, "truth", "truth.json")))
    desc = json.load(open(os.path.join(raw, "capture.json")))
    os.makedirs(work, exist_ok=True)
    result = {"set": name, "dir": raw, "layout": truth.get("layout"), "board": desc["board"],
              "render_seconds": truth.get("seconds"), "stages": {}}
    tcam = truth["camera"]

    def stage(key, fn):
        t0 = time.monotonic()
        try:
            metrics = fn()
            result["stages"][key] = {"ok": True, "seconds": round(time.monotonic() - t0, 1), **metrics}
        except (StepError, OSError, KeyError, ValueError, IndexError) as e:
            result["stages"][key] = {"ok": False, "seconds": round(time.monotonic() - t0, 1),
                                     "error": "%s: %s" % (type(e).__name__, e)}
        print("  %-12s %s" % (key, "ok" if result["stages"][key]["ok"] else "FAILED: " + result["stages"][key]["error"]),
              flush=True)
        return result["stages"][key]["ok"]

    # ---- calibrate
    def calibrate():
        b = desc["board"]
        out = os.path.join(work, "calib")
        cmd = [binary, "calibrate", "--pattern", b["pattern"], "--corners", "%dx%d" % (b["cols"], b["rows"]),
               "--square", repr(b["square"]), "--model", desc["camera"].get("model", "OPENCV"), "--out", out]
        if b["pattern"] == "charuco":
            cmd += ["--marker", repr(b["marker"]), "--dictionary", b["dictionary"]]
        if b.get("layout", "new") != "new":
            cmd += ["--charuco-layout", b["layout"]]
        cmd += [os.path.join(raw, f) for f in desc["calibration_photos"]]
        run(cmd, log)
        cal = json.load(open(os.path.join(out, "calibration.json")))
        m = intrinsics_errors(cal["camera"]["params"], cal["camera"]["model"], tcam)
        pairs = []
        for k, v in enumerate(cal["views"]):
            if v.get("used") and "cam_from_board" in v:
                pairs.append((v["cam_from_board"], truth["calibration_cam_from_world"][k]))
        m.update(summarise("", *pose_errors(pairs)))
        m.update({"rms_px": cal["rms_px"], "used_views": len(pairs), "views": len(cal["views"]),
                  "rejected": [{"image": v["image"], "why": v.get("rejected_because")} for v in cal["views"]
                               if not v.get("used")]})
        return m

    stage("calibrate", calibrate)

    # ---- capture
    cap = os.path.join(work, "capture")

    def capture():
        run([binary, "capture", raw, "--out", cap, "--threads", str(threads)], log)
        scene = json.load(open(os.path.join(cap, "scene.json")))
        rep = json.load(open(os.path.join(cap, "report", "capture_report.json")))
        cam = scene["cameras"][0]
        m = intrinsics_errors(cam["params"], cam["model"], tcam)
        pairs, ious = [], []
        for e in scene["images"]:
            i = int(os.path.splitext(os.path.basename(e["file"]))[0])
            pairs.append((e["cam_from_world"], truth["cam_from_world"][i]))
            if e.get("mask"):
                est = read_mask(os.path.join(cap, e["mask"]))
                tru = read_mask(os.path.join(raw, "truth", "masks", "%04d.png" % i))
                ious.append(float((est & tru).sum() / max(1, (est | tru).sum())))
        m.update(summarise("", *pose_errors(pairs)))
        m["posed_photos"] = len(pairs)
        m["photos"] = len(desc["photos"])
        m["dropped"] = rep.get("dropped_photos", [])
        # Registered mesh vs its true placement, over the mesh's own vertices.
        v = read_obj_vertices(os.path.join(raw, "mesh.obj"))
        rt, tt = pose(truth["world_from_mesh"])
        true_v = v @ rt.T + tt
        for key, p in (("mesh_rms_mm", rep["registration"]["world_from_mesh"]),
                       ("rough_mesh_rms_mm", desc["mesh"]["world_from_mesh"])):
            r, t = pose(p)
            m[key] = float(1e3 * np.sqrt(np.mean(np.sum((v @ r.T + t - true_v) ** 2, axis=1))))
        if ious:
            m.update({"mask_iou_median": float(np.median(ious)), "mask_iou_min": float(min(ious))})
        lights = {l["id"]: l for l in scene["lights"]}
        tl = truth["lamp"]
        if 1 in lights:
            l = lights[1]
            m["lamp_error_mm"] = float(1e3 * np.linalg.norm(np.asarray(l["position"]) - np.asarray(tl["position"])))
            est_i = float(np.mean(l["intensity"])) if isinstance(l["intensity"], list) else float(l["intensity"])
            scale = est_i / float(np.mean(tl["intensity"]))
            m["lamp_intensity_scale"] = scale
            if "white_albedo" in desc["board"]:
                m["lamp_intensity_error_pct"] = 100 * (scale - 1)
            # What the scale would be with the true paper albedo (if capture assumed a).
            m["lamp_intensity_note"] = ("white_albedo given: %s" % desc["board"]["white_albedo"]
                                        if "white_albedo" in desc["board"] else
                                        "no white_albedo in capture.json: scale only (true paper albedo %.2f)"
                                        % truth["board_paper_albedo"])
        m["report_seconds"] = rep.get("seconds")
        return m

    cap_ok = stage("capture", capture)

    # ---- back half, quickly
    mat, relit = os.path.join(work, "material"), os.path.join(work, "relit")
    if cap_ok and front_only:
        rec_ok = False
        result["stages"]["reconstruct"] = {"ok": False, "skipped": "--front-only"}
    elif cap_ok:
        rec_ok = stage("reconstruct", lambda: (run([binary, "reconstruct", os.path.join(cap, "scene.json"), "--out", mat,
                                                    "--max-clusters", "2", "--texture-size", "128", "--normals", "off",
                                                    "--time-budget", "60", "--no-report", "--threads", str(threads)],
                                                   log), {})[1])
    else:
        rec_ok = False
        result["stages"]["reconstruct"] = {"ok": False, "skipped": "capture failed"}

    def relight():
        run([binary, "relight", mat, os.path.join(cap, "scene.json"), "--out", relit, "--spp", "2",
             "--adaptive-rounds", "0", "--threads", str(threads)], log)
        _, out, _ = run([binary, "evaluate", relit, os.path.join(cap, "scene.json")], log)
        ev = parse_evaluate(out)
        ev.pop("per_image")
        return ev

    if rec_ok:
        stage("relight", relight)
    else:
        rs = result["stages"]["reconstruct"]
        result["stages"]["relight"] = {"ok": False, "skipped": "reconstruct " + ("skipped" if rs.get("skipped") else "failed")}
    result["within_limits"] = check_limits(result)
    return result


def check_limits(r):
    out = {}
    for st in ("calibrate", "capture"):
        s = r["stages"].get(st, {})
        if not s.get("ok"):
            continue
        if "focal_error_pct" in s:
            out[st + ".focal"] = abs(s["focal_error_pct"]) <= LIMITS["focal_pct"]
        if "centre_median_mm" in s:
            out[st + ".centres"] = s["centre_median_mm"] <= LIMITS["centre_median_mm"]
            out[st + ".rotations"] = s["rotation_median_deg"] <= LIMITS["rotation_median_deg"]
        if st == "capture":
            if "mesh_rms_mm" in s:
                out["capture.mesh"] = s["mesh_rms_mm"] <= LIMITS["mesh_rms_mm"]
            if "lamp_error_mm" in s:
                out["capture.lamp"] = s["lamp_error_mm"] <= LIMITS["lamp_mm"]
    return out


def fmt(v, spec="%.2f"):
    if v is None:
        return "–"
    if isinstance(v, (int, float)):
        return spec % v
    return str(v)


def markdown(doc):
    lines = ["# Front half on Mitsuba-rendered raw sets (issue 25)", "",
             "Generated by `scripts/bench_front_half.py` on %s; raw sets by `scripts/mitsuba_raw_set.py`. "
             "Limits: camera centres %.0f mm (median), rotations %.1f° (median), mesh %.0f mm RMS, lamp %.0f mm, "
             "focal %.1f %%." % (doc["date"], LIMITS["centre_median_mm"], LIMITS["rotation_median_deg"],
                                 LIMITS["mesh_rms_mm"], LIMITS["lamp_mm"], LIMITS["focal_pct"]), "",
             "## calibrate", "",
             "| set | views used | RMS px | focal % | pp px | centres med / worst mm | rotations med / worst ° |",
             "|---|---|---|---|---|---|---|"]
    for r in doc["sets"]:
        s = r["stages"]["calibrate"]
        if not s.get("ok"):
            lines.append("| %s | failed | | | | | |" % r["set"])
            continue
        lines.append("| %s | %d/%d | %.3f | %+.3f | %.2f | %s / %s | %s / %s |" % (
            r["set"], s["used_views"], s["views"], s["rms_px"], s["focal_error_pct"], s["principal_point_error_px"],
            fmt(s.get("centre_median_mm")), fmt(s.get("centre_worst_mm")), fmt(s.get("rotation_median_deg"), "%.3f"),
            fmt(s.get("rotation_worst_deg"), "%.3f")))
    lines += ["", "## capture", "",
              "| set | posed | focal % | pp px | centres med / worst mm | rotations med / worst ° | mesh RMS mm (rough) "
              "| lamp mm | lamp I est/true | mask IoU med / min | reconstruct | relight |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in doc["sets"]:
        s = r["stages"]["capture"]
        rec = r["stages"].get("reconstruct", {})
        rel = r["stages"].get("relight", {})
        def st(x):
            if not x.get("ok"):
                return "skipped" if x.get("skipped") else "failed"
            if "psnr_mean_db" in x:
                return "%.1f dB mean PSNR" % x["psnr_mean_db"]
            return "ok (%.0f s)" % x["seconds"]
        if not s.get("ok"):
            lines.append("| %s | failed | | | | | | | | | %s | %s |" % (r["set"], st(rec), st(rel)))
            continue
        if rel.get("ok"):
            rel = dict(rel, seconds=rel["seconds"])
        lines.append("| %s | %d/%d | %+.3f | %.2f | %s / %s | %s / %s | %s (%s) | %s | %s | %s / %s | %s | %s |" % (
            r["set"], s["posed_photos"], s["photos"], s["focal_error_pct"], s["principal_point_error_px"],
            fmt(s.get("centre_median_mm")), fmt(s.get("centre_worst_mm")), fmt(s.get("rotation_median_deg"), "%.3f"),
            fmt(s.get("rotation_worst_deg"), "%.3f"), fmt(s.get("mesh_rms_mm")), fmt(s.get("rough_mesh_rms_mm"), "%.1f"),
            fmt(s.get("lamp_error_mm"), "%.1f"), fmt(s.get("lamp_intensity_scale"), "%.3f"),
            fmt(s.get("mask_iou_median"), "%.3f"), fmt(s.get("mask_iou_min"), "%.3f"), st(rec), st(rel)))
    lines += ["", "## limits", ""]
    for r in doc["sets"]:
        w = r.get("within_limits", {})
        if w:
            lines.append("- %s: " % r["set"] + ", ".join("%s %s" % (k, "✓" if v else "✗") for k, v in sorted(w.items())))
    lines += ["", "## failures", ""]
    any_fail = False
    for r in doc["sets"]:
        for k, s in r["stages"].items():
            if not s.get("ok") and "error" in s:
                any_fail = True
                lines.append("- **%s / %s**: `%s`" % (r["set"], k, s["error"].replace("`", "'")))
    if not any_fail:
        lines.append("none")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sets", nargs="+", help="raw set folders (capture.json + truth/truth.json)")
    ap.add_argument("--out", default="bench_results/front_half_mitsuba.json")
    ap.add_argument("--work", default="/work/scratch/front_half_bench", help="outputs of the stages")
    ap.add_argument("--bin", default=DEFAULT_BIN)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--front-only", action="store_true", help="calibrate and capture only")
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    doc = {"date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"), "binary": args.bin, "limits": LIMITS,
           "sets": []}
    for raw in args.sets:
        name = os.path.basename(raw.rstrip("/"))
        print(name, flush=True)
        work = os.path.join(args.work, name)
        log = os.path.join(args.work, name + ".log")
        if os.path.exists(log):
            os.remove(log)
        doc["sets"].append(bench_set(raw, work, args.bin, args.threads, log, args.front_only))
        # Written after every set: a long run leaves its results so far.
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "w") as f:
            json.dump(doc, f, indent=1)
        md = os.path.splitext(args.out)[0] + ".md"
        with open(md, "w") as f:
            f.write(markdown(doc))
    print("wrote %s and %s" % (args.out, md))


if __name__ == "__main__":
    sys.exit(main())
