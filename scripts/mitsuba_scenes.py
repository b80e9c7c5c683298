#!/usr/bin/env python3
"""Randomized Mitsuba 3 captures for the generalization benchmark (issue 24):
from an integer seed, draws a scene and renders it as a capture in the dataset
contract with scripts/mitsuba_capture.py's renderer (`render_capture`).

What a seed draws (`draw_scene`, numpy only, no Mitsuba needed):
  shape      sphere or torus (with or without texture coordinates, 32-64
             segments) or a scan of Debian's libcgal-demo data (scan_mesh.py,
             decimated to 2000-6000 triangles, no texture coordinates)
  materials  1-5 per object, each from one of Mitsuba's families: diffuse;
             plastic; roughplastic (GGX or Beckmann, alpha 0.05-0.5, ior
             1.3-1.8); conductor / roughconductor with a named metal (Cu, Au,
             Ag, Al, Cr, W, Hg, Be); principled (metallic, specular,
             roughness, sometimes clearcoat); a coating: a clear
             dielectric-Fresnel specular layer (roughconductor with a real
             eta, k = 0) blended over a diffuse by a blendbsdf
  blend map  per-vertex weights of the materials (mitsuba_capture.paint):
             sharp (4 mm borders), soft (15-60 mm) or noisy (borders bent by
             random plane waves of 20-60 mm amplitude)
  lights     point lamps, a flash beside the lens, directional lights, or a
             mix, intensity scaled by 0.6-1.6
  photos     24-60 training photos + 8-12 held-out views (each photo has its
             own light, so held-out lights are never used for fitting),
             320x240, 0-2 % relative Gaussian noise, path tracer with 2
             indirect bounces (interreflection), 32 spp
The drawn parameters go to CAP/truth/scene_params.json (len(materials) is
the true count), the per-vertex weights to CAP/truth/vertex_weights.npy,
the held-out views rendered again (64 spp, independent seed, no added
noise) to CAP/truth/ceiling/, the render time to CAP/truth/render.json.

Usage (the Mitsuba venv):
  /work/scratch/mi/bin/python scripts/mitsuba_scenes.py --show 5          # print seed 5's draw
  /work/scratch/mi/bin/python scripts/mitsuba_scenes.py 5 --out CAP       # render seed 5
  /work/scratch/mi/bin/python scripts/mitsuba_scenes.py --freeze bench_results/generalization_scenes.json
      (draw seeds 1..24, split odd seeds = dev / even seeds = test, record the
      sampler's source hash; --record-times DIR adds the render times of the
      captures cached in DIR/<seed>/)
scripts/bench_generalization.py renders missing scenes and measures them.
"""
import argparse
import datetime
import hashlib
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import mitsuba_capture as mc  # noqa: E402
import scan_mesh  # noqa: E402

# The files whose code decides what a seed renders: a change to any of them
# changes the benchmark (the runner refuses to compare across it).
SOURCES = ["mitsuba_scenes.py", "mitsuba_capture.py", "scan_mesh.py"]
SCANS = ["bunny00", "armadillo", "elephant", "cow", "bull", "homer", "camel", "triceratops", "elk", "bear"]
METALS = ["Cu", "Au", "Ag", "Al", "Cr", "W", "Hg", "Be"]
FAMILIES = ["diffuse", "plastic", "roughplastic", "conductor", "roughconductor", "principled", "coating"]
FAMILY_P = [0.17, 0.07, 0.22, 0.05, 0.21, 0.18, 0.10]
LIGHT_MIXES = [["point"], ["point", "flash"], ["directional"], ["point", "directional"],
               ["flash", "directional"], ["point", "flash", "directional"]]
WIDTH, HEIGHT, SPP, CEILING_SPP, BOUNCES = 320, 240, 32, 64, 2
SEEDS = range(1, 25)
SPLIT_RULE = "odd seeds are the dev half, even seeds the test half"


def sampler_hash():
    """sha256 over the sampler's sources (SOURCES, in order)."""
    h = hashlib.sha256()
    for name in SOURCES:
        h.update(name.encode() + b"\0" + open(os.path.join(HERE, name), "rb").read())
    return h.hexdigest()


def split_of(seed):
    return "dev" if seed % 2 == 1 else "test"


def _rgb(rng, lo=0.02, hi=0.85):
    return {"type": "rgb", "value": [round(float(x), 4) for x in rng.uniform(lo, hi, 3)]}


def _log_uniform(rng, lo, hi):
    return round(float(np.exp(rng.uniform(np.log(lo), np.log(hi)))), 4)


def draw_material(rng):
    """(family, Mitsuba BSDF dict) of one material."""
    family = str(rng.choice(FAMILIES, p=FAMILY_P))
    ior = round(float(rng.uniform(1.3, 1.8)), 4)
    dist = str(rng.choice(["ggx", "beckmann"]))
    if family == "diffuse":
        bsdf = {"type": "diffuse", "reflectance": _rgb(rng)}
    elif family == "plastic":
        bsdf = {"type": "plastic", "int_ior": ior, "ext_ior": 1.0, "diffuse_reflectance": _rgb(rng),
                "nonlinear": False}
    elif family == "roughplastic":
        bsdf = {"type": "roughplastic", "distribution": dist, "alpha": _log_uniform(rng, 0.05, 0.5), "int_ior": ior,
                "ext_ior": 1.0, "diffuse_reflectance": _rgb(rng), "nonlinear": False}
    elif family == "conductor":
        bsdf = {"type": "conductor", "material": str(rng.choice(METALS))}
    elif family == "roughconductor":
        bsdf = {"type": "roughconductor", "material": str(rng.choice(METALS)), "distribution": dist,
                "alpha": _log_uniform(rng, 0.05, 0.5)}
    elif family == "principled":
        metallic = float(rng.choice([0.0, 1.0, rng.uniform(0, 1)]))
        bsdf = {"type": "principled", "base_color": _rgb(rng), "metallic": round(metallic, 4),
                "specular": round(float(rng.uniform(0.1, 1.0)), 4),
                "roughness": round(float(rng.uniform(0.1, 0.8)), 4)}
        if rng.random() < 0.4:
            bsdf["clearcoat"] = round(float(rng.uniform(0.2, 1.0)), 4)
            bsdf["clearcoat_gloss"] = round(float(rng.uniform(0.3, 1.0)), 4)
    else:  # coating: a clear layer with dielectric Fresnel (real eta, k = 0) over a diffuse base
        bsdf = {"type": "blendbsdf", "weight": round(float(rng.uniform(0.25, 0.7)), 4),
                "bsdf_0": {"type": "diffuse", "reflectance": _rgb(rng)},
                "bsdf_1": {"type": "roughconductor", "distribution": dist, "alpha": _log_uniform(rng, 0.03, 0.3),
                           "eta": ior, "k": 0.0}}
    return family, bsdf


def draw_scene(seed):
    """The parameters of seed's scene (a JSON-serialisable dict)."""
    rng = np.random.default_rng([seed, 0])
    kind = str(rng.choice(["sphere", "torus", "scan"], p=[0.25, 0.25, 0.5]))
    if kind == "scan":
        shape = {"kind": "scan", "name": str(rng.choice(SCANS)), "faces": int(rng.integers(2000, 6001)),
                 "uvs": False}
    else:
        shape = {"kind": kind, "detail": int(rng.integers(32, 65)), "uvs": bool(rng.random() < 0.5)}
    materials = []
    for i in range(int(rng.integers(1, 6))):
        family, bsdf = draw_material(rng)
        materials.append({"name": "m%d_%s" % (i, family), "family": family, "bsdf": bsdf})
    blend_kind = str(rng.choice(["sharp", "soft", "noisy"]))
    blend = {"kind": blend_kind}
    if blend_kind == "sharp":
        blend["border"] = 0.004
    elif blend_kind == "soft":
        blend["border"] = round(float(rng.uniform(0.015, 0.06)), 4)
    else:
        blend.update(border=round(float(rng.uniform(0.005, 0.02)), 4),
                     amplitude=round(float(rng.uniform(0.02, 0.06)), 4),
                     wavenumber=round(float(rng.uniform(8.0, 25.0)), 3), waves=8)
    views, heldout = int(rng.integers(24, 61)), int(rng.integers(8, 13))
    mix = LIGHT_MIXES[int(rng.integers(len(LIGHT_MIXES)))]
    plan = [str(rng.choice(mix)) for _ in range(views + heldout)]
    scale = round(float(rng.uniform(0.6, 1.6)), 4)
    lights = {"mix": mix, "scale": scale, "point_intensity": round(10.0 * scale, 4),
              "flash_intensity": round(6.0 * scale, 4), "directional_irradiance": round(1.6 * scale, 4),
              "plan": plan}
    return {"seed": seed, "shape": shape, "materials": materials, "true_count": len(materials), "blend": blend,
            "lights": lights, "views": views, "heldout": heldout, "noise": round(float(rng.uniform(0.0, 0.02)), 5),
            "width": WIDTH, "height": HEIGHT, "spp": SPP, "ceiling_spp": CEILING_SPP, "bounces": BOUNCES}


def geometry(params):
    """(v, uv or None, faces) of the drawn shape, inside a ball of radius 0.5."""
    shape = params["shape"]
    if shape["kind"] == "sphere":
        v, uv, f = mc.sphere(shape["detail"])
    elif shape["kind"] == "torus":
        v, uv, f = mc.torus(shape["detail"])
    else:
        v, f = scan_mesh.load(shape["name"], shape["faces"])
        v = mc.normalize(v)
        # Mitsuba's BSDFs are one-sided: face the triangles outwards (positive signed volume).
        if np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() < 0:
            f = f[:, ::-1].copy()
        uv = None
    return v, (uv if shape["uvs"] else None), f


def weights(params, v, rng):
    """Per-vertex weights (n, true_count) of the drawn blend map."""
    k, blend = params["true_count"], params["blend"]
    if k == 1:
        return np.ones((len(v), 1))
    jitter = None
    if blend["kind"] == "noisy":
        wave_rng = np.random.default_rng([params["seed"], 2])
        dirs = wave_rng.normal(size=(k, blend["waves"], 3))
        dirs *= blend["wavenumber"] * 2 * np.pi / np.linalg.norm(dirs, axis=2, keepdims=True)
        phase = wave_rng.uniform(0, 2 * np.pi, (k, blend["waves"]))

        def jitter(p):
            waves = np.sin(np.einsum("nd,kwd->nkw", p, dirs) + phase[None])
            return blend["amplitude"] * waves.sum(2) / np.sqrt(blend["waves"] / 2)
    return mc.paint(v, rng, blend["border"], regions=k, jitter=jitter)


def render_scene(params, out, log=print):
    """Renders params' scene into the capture folder out; returns the render seconds."""
    rng = np.random.default_rng([params["seed"], 1])
    v, uv, f = geometry(params)
    w = weights(params, v, rng)
    plan, lights = params["lights"]["plan"], params["lights"]
    import mitsuba as mi
    seconds = mc.render_capture(
        out, v, uv, f, w, [(m["name"], m["bsdf"]) for m in params["materials"]], rng, views=params["views"],
        heldout=params["heldout"], width=params["width"], height=params["height"], spp=params["spp"],
        bounces=params["bounces"], noise=params["noise"], seed=params["seed"],
        light_kind=lambda k, held: plan[k], point_intensity=lights["point_intensity"],
        flash_intensity=lights["flash_intensity"], directional_irradiance=lights["directional_irradiance"],
        ceiling_spp=params["ceiling_spp"],
        truth_extra={"scene_params": "truth/scene_params.json (scripts/mitsuba_scenes.py seed %d)" % params["seed"]},
        truth_files={"scene_params.json": params}, log=log)
    info = {"render_s": round(seconds, 1), "mitsuba": mi.__version__, "sampler_sha256": sampler_hash(),
            "vertices": len(v), "triangles": len(f),
            "date": datetime.datetime.now().isoformat(timespec="seconds")}
    with open(os.path.join(out, "truth", "render.json"), "w") as fh:
        json.dump(info, fh, indent=1)
    return seconds


def freeze(path, seeds, cache=None):
    """Writes the frozen manifest of seeds (parameters, split, sampler hash)."""
    scenes = []
    for seed in seeds:
        entry = {"seed": seed, "split": split_of(seed), "params": draw_scene(seed)}
        info = os.path.join(cache, str(seed), "truth", "render.json") if cache else None
        if info and os.path.exists(info):
            entry["render"] = json.load(open(info))
        scenes.append(entry)
    doc = {"format": "svbrdf-generalization-scenes/1",
           "frozen": datetime.date.today().isoformat(),
           "sampler": "scripts/mitsuba_scenes.py (draw_scene, render_scene)",
           "sampler_sources": SOURCES, "sampler_sha256": sampler_hash(),
           "split_rule": SPLIT_RULE, "scenes": scenes}
    if os.path.exists(path):  # keep the freezing date of an unchanged sampler
        old = json.load(open(path))
        if old.get("sampler_sha256") == doc["sampler_sha256"]:
            doc["frozen"] = old.get("frozen", doc["frozen"])
    with open(path, "w") as fh:
        json.dump(doc, fh, indent=1)
    print("froze %d scenes (%s) -> %s" % (len(scenes), SPLIT_RULE, path))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("seed", nargs="?", type=int, help="render this seed's scene (with --out)")
    ap.add_argument("--out", help="capture folder")
    ap.add_argument("--show", type=int, metavar="SEED", help="print SEED's drawn parameters")
    ap.add_argument("--freeze", metavar="MANIFEST", help="write the frozen manifest of seeds 1..24")
    ap.add_argument("--record-times", metavar="CACHE", help="with --freeze: add render times from CACHE/<seed>/")
    a = ap.parse_args()
    if a.show is not None:
        print(json.dumps(draw_scene(a.show), indent=1))
    elif a.freeze:
        freeze(a.freeze, SEEDS, a.record_times)
    elif a.seed is not None and a.out:
        s = render_scene(draw_scene(a.seed), a.out, log=lambda m: print(m, flush=True))
        print("capture: %s/scene.json in %.0f s" % (a.out, s))
    else:
        ap.error("give SEED --out DIR, --show SEED or --freeze MANIFEST")


if __name__ == "__main__":
    sys.exit(main())
