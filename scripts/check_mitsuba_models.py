#!/usr/bin/env python3
"""Per-model agreement of `svbrdf export --format mitsuba` with `relight`:
one small synthetic capture per model family (ground-truth material, point
lights only so that the emitters are exact), rendered with Mitsuba 3 by
scripts/check_mitsuba_export.py. Writes bench_results/mitsuba_models.{json,md}.

    /work/scratch/mi/bin/python scripts/check_mitsuba_models.py --work out/mitsuba_models

"material" compares Mitsuba with relight of the ground truth (includes the
nearest-form error of the family); "as_rendered" with relight of the
export's as_rendered/ material (the forms as our models: exact for
roughconductor and plastic; for roughplastic ours, so it keeps the base-term
difference).
"""
import argparse
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
COMMON = {"object": "sphere", "detail": 48, "num_images": 4, "num_heldout": 2, "width": 160, "height": 120,
          "lights": "point", "format": "exr", "noise": 0, "spp": 1, "seed": 5}
METALS = [("gold", 0.25), ("copper", 0.15), ("aluminium", 0.35)]


def metals(model_of):
    return {"num_materials": 3, "models": [model_of(i) for i in range(3)],
            "params": [{"metal": m, "roughness": r} for m, r in METALS], "texture_size": 64, "blend": 0.02}


def coated(dist):
    return {"num_materials": 2, "models": [f"coated-{dist}"] * 2,
            "params": [{"rd_r": 0.6, "rd_g": 0.07, "rd_b": 0.05, "roughness": 0.06, "ior": 1.5},
                       {"rd_r": 0.08, "rd_g": 0.2, "rd_b": 0.55, "roughness": 0.3, "ior": 1.5}],
            "texture_size": 64, "blend": 0.02}


FAMILIES = {
    "conductor (exact eta, kappa)": metals(lambda i: ["conductor-ggx", "conductor-beckmann", "conductor-ggx"][i]),
    "conductor-schlick": metals(lambda i: ["conductor-ggx-schlick", "conductor-beckmann-schlick", "conductor-ggx-schlick"][i]),
    "conductor-f82": metals(lambda i: ["conductor-ggx-f82", "conductor-beckmann-f82", "conductor-ggx-f82"][i]),
    "coated-ggx": coated("ggx"),
    "coated-beckmann": coated("beckmann"),
    "plastic": {"num_materials": 2, "models": ["plastic"] * 2,
                "params": [{"rd_r": 0.6, "rd_g": 0.07, "rd_b": 0.05, "ior": 1.5},
                           {"rd_r": 0.08, "rd_g": 0.2, "rd_b": 0.55, "ior": 1.33}],
                "texture_size": 64, "blend": 0.02},
}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cli", default=os.path.join(HERE, "..", "build", "apps", "svbrdf"))
    ap.add_argument("--work", default="out/mitsuba_models")
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--out", default=os.path.join(HERE, "..", "bench_results", "mitsuba_models"))
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    rows = []
    for i, (family, material) in enumerate(FAMILIES.items()):
        d = os.path.join(args.work, f"f{i}")
        os.makedirs(d, exist_ok=True)
        cfg = dict(COMMON, material=material)
        with open(os.path.join(d, "synth.json"), "w") as f:
            json.dump(cfg, f, indent=1)
        subprocess.run([args.cli, "synth", "--config", os.path.join(d, "synth.json"), "--out", os.path.join(d, "capture")],
                       check=True, stdout=subprocess.DEVNULL)
        subprocess.run([sys.executable, os.path.join(HERE, "check_mitsuba_export.py"), os.path.join(d, "capture", "gt"),
                        os.path.join(d, "capture", "heldout", "scene.json"), "--work", os.path.join(d, "check"),
                        "--cli", args.cli, "--spp", str(args.spp)], check=True)
        a = json.load(open(os.path.join(d, "check", "agreement.json")))
        rep = a["export_report"]
        rows.append({"family": family, "models": material["models"],
                     "mapping": [b["mapping"] for b in rep["basis"]],
                     "form_relative_error": [b["relative_error"] for b in rep["basis"]],
                     "max_fresnel_error": [b.get("lobe", {}).get("max_fresnel_error", 0) for b in rep["basis"]],
                     "material": a["material_mask"], "as_rendered": a["as_rendered_mask"],
                     "material_interior": a["material_interior"]})
        print(f"{family}: {a['material_mask']['mean_psnr_srgb']:.2f} dB vs ground truth, "
              f"{a['as_rendered_mask']['mean_psnr_srgb']:.2f} dB vs as_rendered", flush=True)
    result = {"mitsuba": a["mitsuba"], "variant": "scalar_rgb", "mitsuba_spp": args.spp, "relight_spp": "4x4 jittered",
              "capture": dict(COMMON, note="per family: synth ground truth, 2 held-out views, point lights"),
              "families": rows}
    with open(args.out + ".json", "w") as f:
        json.dump(result, f, indent=2)
    with open(args.out + ".md", "w") as f:
        f.write(f"# Mitsuba 3 export: agreement per model family\n\n"
                f"`scripts/check_mitsuba_models.py`: Mitsuba {a['mitsuba']} scalar_rgb, {args.spp} spp, box filter, vs "
                f"`svbrdf relight --spp 4` of the synthetic ground truth; 2 held-out views of a 160x120 sphere under "
                f"point lights per family; PSNR on sRGB inside relight's masks (as `evaluate`), relative RMSE on linear RGB. "
                f"Form error: relative RMSE of the Mitsuba form vs our model over the export's direction pairs "
                f"(export_report.json).\n\n"
                f"| family | Mitsuba vs ground truth (mean PSNR) | min | rel. RMSE | form error per basis | max abs dF |\n"
                f"|---|---|---|---|---|---|\n")
        for r in rows:
            f.write(f"| {r['family']} | {r['material']['mean_psnr_srgb']:.1f} dB | {r['material']['min_psnr_srgb']:.1f} dB | "
                    f"{r['material']['mean_rel_rmse_linear']:.4f} | "
                    f"{', '.join(f'{e:.4f}' for e in r['form_relative_error'])} | "
                    f"{max(r['max_fresnel_error']):.4f} |\n")
    print(f"wrote {args.out}.json and .md")


if __name__ == "__main__":
    sys.exit(main())
