#!/usr/bin/env python3
"""Renders `svbrdf export --format mitsuba` scenes with Mitsuba 3 and compares
them with `svbrdf relight`'s images of the same views, inside relight's masks.

Needs the Mitsuba 3 wheel (not a Debian package), e.g.
    python3 -m venv /work/scratch/mi && /work/scratch/mi/bin/pip install mitsuba
    /work/scratch/mi/bin/python scripts/check_mitsuba_export.py out/demo/material \
        out/demo/capture/heldout/scene.json --work out/mitsuba_check

Steps: export (one view file per image entry of SCENE.json), relight with
--spp 4 (16 jittered samples per pixel: pixel-area averages like Mitsuba's box
filter) both the material and the export's as_rendered/ material (every basis
material replaced by its Mitsuba form), render every view with the scalar_rgb
variant, then per view and for each reference ("material": end to end,
including the nearest-form error of models Mitsuba lacks; "as_rendered": the
export and the two renderers alone; "photos": the scene's own photos, e.g. the
held-out photos of a capture, which is what a user of the export sees;
"relight_vs_photos" scores relight's image against the same photos):
relative RMSE = sqrt(sum (m - r)^2 / sum r^2) over linear RGB, and PSNR on
sRGB-encoded values clipped to [0, 1] after dividing by the exposure (as
`svbrdf evaluate` computes it), over relight's mask and over the mask eroded
by one pixel (silhouette pixels excluded). Writes WORK/agreement.json.
"""
import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np


def srgb(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def metrics(mi_img, ref, mask, exposure):
    m = mask > 0
    if not m.any():
        return {"pixels": 0}
    a, b = mi_img[m] / exposure, ref[m] / exposure
    rel = float(np.sqrt(np.sum((a - b) ** 2) / max(np.sum(b ** 2), 1e-30)))
    mse = float(np.mean((srgb(a) - srgb(b)) ** 2))
    psnr = float(10 * np.log10(1.0 / mse)) if mse > 0 else float("inf")
    return {"pixels": int(m.sum()), "rel_rmse_linear": rel, "psnr_srgb": psnr}


def erode(mask):
    m = mask > 0
    e = m.copy()
    e[1:, :] &= m[:-1, :]
    e[:-1, :] &= m[1:, :]
    e[:, 1:] &= m[:, :-1]
    e[:, :-1] &= m[:, 1:]
    return e


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("material")
    ap.add_argument("scene")
    ap.add_argument("--cli", default=os.path.join(os.path.dirname(__file__), "..", "build", "apps", "svbrdf"))
    ap.add_argument("--work", default="out/mitsuba_check")
    ap.add_argument("--spp", type=int, default=256, help="Mitsuba samples per pixel")
    ap.add_argument("--views", type=int, default=0, help="compare only the first N views (0 = all)")
    args = ap.parse_args()

    import mitsuba as mi
    mi.set_variant("scalar_rgb")

    os.makedirs(args.work, exist_ok=True)
    exp_dir, relit_dir = os.path.join(args.work, "mitsuba"), os.path.join(args.work, "relit")
    subprocess.run([args.cli, "export", args.material, "--format", "mitsuba", "--scene", args.scene, "--out", exp_dir,
                    "--spp", str(args.spp)], check=True)
    subprocess.run([args.cli, "relight", args.material, args.scene, "--out", relit_dir, "--spp", "4"], check=True)
    relit_forms_dir = os.path.join(args.work, "relit_as_rendered")
    subprocess.run([args.cli, "relight", os.path.join(exp_dir, "as_rendered"), args.scene, "--out", relit_forms_dir,
                    "--spp", "4"], check=True)
    views = json.load(open(os.path.join(exp_dir, "views.json")))
    if args.views > 0:
        views = views[: args.views]
    results = []
    for v in views:
        t0 = time.time()
        scene = mi.load_file(os.path.join(exp_dir, v["xml"]))
        img = np.array(mi.render(scene, seed=1), dtype=np.float64)[..., :3]
        secs = time.time() - t0
        mi.Bitmap(img.astype(np.float32)).write(os.path.join(args.work, os.path.basename(v["image"]).rsplit(".", 1)[0] + "_mitsuba.exr"))
        mask_rel = v["mask"] if v["mask"] else os.path.splitext(v["image"])[0] + ".mask.png"
        r = {"view": v["image"], "render_s": round(secs, 2)}
        scene_dir = os.path.dirname(os.path.abspath(args.scene))
        relit_img = None
        for name, d in (("material", relit_dir), ("as_rendered", relit_forms_dir), ("photos", scene_dir)):
            ref = np.array(mi.Bitmap(os.path.join(d, v["image"])), dtype=np.float64)[..., :3]
            mask = np.array(mi.Bitmap(os.path.join(d if name != "photos" else relit_dir, mask_rel)), dtype=np.float64)
            mask = mask.reshape(mask.shape[0], mask.shape[1], -1)[..., 0]
            r[name] = {"mask": metrics(img, ref, mask, v["exposure"]), "interior": metrics(img, ref, erode(mask), v["exposure"])}
            if name == "material":
                relit_img = ref
            if name == "photos":
                r["relight_vs_photos"] = {"mask": metrics(relit_img, ref, mask, v["exposure"]),
                                          "interior": metrics(relit_img, ref, erode(mask), v["exposure"])}
        results.append(r)
        print(f"{v['image']} ({secs:.1f} s): " + "; ".join(
            f"vs relight of {n}: {r[n]['mask']['psnr_srgb']:.2f} dB, rel RMSE {r[n]['mask']['rel_rmse_linear']:.4f} "
            f"(interior {r[n]['interior']['psnr_srgb']:.2f} dB, {r[n]['interior']['rel_rmse_linear']:.4f})"
            for n in ("material", "as_rendered", "photos")) +
            f"; relight vs photos {r['relight_vs_photos']['mask']['psnr_srgb']:.2f} dB", flush=True)
    summary = {"material": args.material, "scene": args.scene, "mitsuba": mi.__version__, "variant": "scalar_rgb",
               "mitsuba_spp": args.spp, "relight_spp": "4x4 jittered", "views": results,
               "export_report": json.load(open(os.path.join(exp_dir, "export_report.json")))}
    for n in ("material", "as_rendered", "photos", "relight_vs_photos"):
        for region in ("mask", "interior"):
            summary[f"{n}_{region}"] = {
                "mean_psnr_srgb": float(np.mean([r[n][region]["psnr_srgb"] for r in results])),
                "min_psnr_srgb": float(np.min([r[n][region]["psnr_srgb"] for r in results])),
                "mean_rel_rmse_linear": float(np.mean([r[n][region]["rel_rmse_linear"] for r in results])),
                "max_rel_rmse_linear": float(np.max([r[n][region]["rel_rmse_linear"] for r in results]))}
        s = summary[f"{n}_mask"]
        print(f"mean over {len(results)} views, Mitsuba vs relight of {n}: {s['mean_psnr_srgb']:.2f} dB "
              f"(min {s['min_psnr_srgb']:.2f}), rel RMSE {s['mean_rel_rmse_linear']:.4f} (max {s['max_rel_rmse_linear']:.4f})")
    with open(os.path.join(args.work, "agreement.json"), "w") as f:
        json.dump(summary, f, indent=2)
    print(f"wrote {os.path.join(args.work, 'agreement.json')}")


if __name__ == "__main__":
    sys.exit(main())
