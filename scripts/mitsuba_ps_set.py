#!/usr/bin/env python3
"""Synthetic photometric-stereo objects in DiLiGenT's layout, rendered by
Mitsuba 3: evidence for `scripts/bench_diligent.py` in the conditions of the
DiLiGenT objects we do not have (metals, metallic paint, several materials
with cast shadows, shiny coatings), on captures the project neither made nor
tuned to.

What a seed draws (`draw_object`, numpy only, rng = default_rng([seed, 7]),
a stream independent of mitsuba_scenes.py's [seed, 0] / [seed, 1]):
  shape      a scan of Debian's libcgal-demo data (mitsuba_scenes.SCANS via
             scan_mesh.py, decimated to 3000-8000 triangles; 70 %), a sphere
             (15 %) or a torus (15 %), turned by a drawn rotation (yaw 0-360,
             pitch and roll within +-25 deg; the torus pitched 25-65 deg so its
             hole casts shadows), shading normals Mitsuba's own
             (angle-weighted vertex normals, as mitsuba_capture.render_capture)
  materials  1-4 (p = .15/.30/.30/.25), each from mitsuba_scenes.draw_material
             (rejection-sampled until it is of a kind drawn first, biased
             towards the hard cases): roughconductor 22 %, near-mirror
             conductor 10 %, principled with metallic >= 0.3 18 % (metallic
             paint, sometimes clearcoat), coating 15 %, principled (any) 5 %,
             roughplastic 13 %, diffuse 12 %, plastic 5 %. A smooth conductor
             (a delta BSDF) under delta (directional) lights and a black
             environment renders black, so the near-mirror kind takes
             draw_material's named metal as a GGX roughconductor with alpha
             0.015-0.05 (still mostly a few saturated pixels per photo)
  blend map  per-vertex weights (mitsuba_scenes.weights -> mitsuba_capture.
             paint, region seeds from default_rng(paint_seed), waves of the
             noisy kind from default_rng([wave_seed, 2]); both seeds drawn
             here): sharp (4 mm borders), soft (15-60 mm) or noisy (borders
             bent by plane waves of 20-60 mm), the object inside a ball of
             radius 0.5; materials mixed by nested `blendbsdf`s over mesh
             attributes (mitsuba_capture.blend_material / blend_attributes)
  lights     the 96 real DiLiGenT directions (cat/light_directions.txt, copied
             verbatim), one Mitsuba `directional` emitter per photo with
             irradiance = light_intensities.txt's row: per light a level
             log-uniform in 0.3-1.7 times a per-object channel tint
             (1, 1-1.3, 1-1.75) times +-5 % per channel, clipped to 0.3-3
             (DiLiGenT's lights are 0.3-1.8 / 0.36-2.2 / 0.47-3.1 per channel)
  exposure   a target median drawn in 5-15 (of 255)
Rendering (`render_object`, scalar_rgb): world = DiLiGenT's camera frame (x
right, y up, z towards the camera); an `orthographic` sensor at z = +3
looking down -z with up +y, the object's projected bounding box centred and
its larger side ~80 % of the 160x160 image; box pixel filter; path tracer
max_depth 4 (direct light + 2 indirect bounces: cast shadows and
interreflection), 32 spp, an independent sampler seed per photo. Every photo
is rendered with its own light's intensity; one exposure per object maps the
median of the grey value (channel mean) over all 96 photos x mask pixels to
the drawn target; then, as DiLiGenT's 8-bit copies, a 16-bit raw =
round(65535 x value) clipped, divided by 256 and floored (255 = saturated).
An `aov` integrator pass (64 spp, `sh_normal` and the film's alpha) gives
mask.png (alpha >= 0.5) and normal_gt.exr (the pixel's mean shading normal,
renormalised, zero outside the mask; the world is the camera frame, so no
transform). `--check-sphere DIR` renders a diffuse sphere with the same code
and prints the sign checks (centre normal ~(0,0,1), right edge ~(1,0,0), a
light from +x lights the right side) and the Lambertian least-squares error.

Output per object (OUT/psNN, NN = seed; written to psNN.partial, renamed when
complete): 001.png ... 096.png (8-bit RGB linear), filenames.txt,
light_directions.txt, light_intensities.txt, mask.png, normal_gt.exr, and
truth/params.json (the draw, plus what rendering derived: exposure, medians,
saturated fraction, times), truth/vertex_weights.npy, truth/mesh.obj (the
rotated, placed mesh in the camera frame; Mitsuba recomputes its normals).

Usage (the Mitsuba venv; folders that are complete are kept, not re-rendered):
  /work/scratch/mi/bin/python scripts/mitsuba_ps_set.py --seeds 1-6 --out /work/scratch/ps_synth
  /work/scratch/mi/bin/python scripts/mitsuba_ps_set.py --show 3
  /work/scratch/mi/bin/python scripts/mitsuba_ps_set.py --check-sphere /tmp/ps_check
Then: /usr/bin/python3 scripts/bench_diligent.py --data /work/scratch/ps_synth \\
        --objects ps01,ps02,ps03,ps04,ps05,ps06 --out bench_results/diligent_synth
"""
import argparse
import datetime
import hashlib
import json
import os
import shutil
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import mitsuba_capture as mc  # noqa: E402
import mitsuba_scenes as ms  # noqa: E402

SOURCES = ["mitsuba_ps_set.py", "mitsuba_scenes.py", "mitsuba_capture.py", "scan_mesh.py"]
DILIGENT_LIGHTS = "/work/shared/data/diligent/cat/light_directions.txt"
WIDTH = HEIGHT = 160
FILL = 0.8
SPP, AOV_SPP, MAX_DEPTH = 32, 64, 4
CAMERA_Z = 3.0
# (kind, probability, family drawn by mitsuba_scenes.draw_material, predicate on its BSDF dict)
KINDS = [
    ("roughconductor", 0.22, "roughconductor", None),
    ("near_mirror_conductor", 0.10, "conductor", None),
    ("principled_metallic", 0.18, "principled", lambda b: b["metallic"] >= 0.3),
    ("coating", 0.15, "coating", None),
    ("principled", 0.05, "principled", None),
    ("roughplastic", 0.13, "roughplastic", None),
    ("diffuse", 0.12, "diffuse", None),
    ("plastic", 0.05, "plastic", None),
]
FILES = ["filenames.txt", "light_directions.txt", "light_intensities.txt", "mask.png", "normal_gt.exr",
         "truth/params.json"]


def sampler_hash():
    h = hashlib.sha256()
    for name in SOURCES:
        h.update(name.encode() + b"\0" + open(os.path.join(HERE, name), "rb").read())
    return h.hexdigest()


def light_rows():
    """The DiLiGenT light directions as text rows (verbatim) and as unit vectors."""
    rows = [l.strip() for l in open(DILIGENT_LIGHTS) if l.strip()]
    d = np.array([[float(x) for x in r.split()] for r in rows])
    return rows, d / np.linalg.norm(d, axis=1, keepdims=True)


def draw_material_of_kind(rng, kind):
    """mitsuba_scenes.draw_material, redrawn until its family (and predicate) fit `kind`."""
    _, _, family, pred = next(k for k in KINDS if k[0] == kind)
    for _ in range(10000):
        fam, bsdf = ms.draw_material(rng)
        if fam == family and (pred is None or pred(bsdf)):
            break
    else:
        raise RuntimeError("no %s material drawn" % kind)
    if kind == "near_mirror_conductor":
        bsdf = {"type": "roughconductor", "material": bsdf["material"], "distribution": "ggx",
                "alpha": ms._log_uniform(rng, 0.015, 0.05)}
    return family, bsdf


def rotation(yaw, pitch, roll):
    """R = Rz(roll) Rx(pitch) Ry(yaw), angles in degrees."""
    a, b, c = np.radians([yaw, pitch, roll])
    ry = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return rz @ rx @ ry


def draw_object(seed):
    """The parameters of seed's object (a JSON-serialisable dict)."""
    rng = np.random.default_rng([seed, 7])
    kind = str(rng.choice(["scan", "sphere", "torus"], p=[0.7, 0.15, 0.15]))
    if kind == "scan":
        shape = {"kind": "scan", "name": str(rng.choice(ms.SCANS)), "faces": int(rng.integers(3000, 8001)),
                 "uvs": False}
    else:
        shape = {"kind": kind, "detail": int(rng.integers(48, 65)), "uvs": False}
    pitch = rng.uniform(25, 65) * rng.choice([-1, 1]) if kind == "torus" else rng.uniform(-25, 25)
    shape["rotation_deg"] = {"yaw": round(float(rng.uniform(0, 360)), 2), "pitch": round(float(pitch), 2),
                             "roll": round(float(rng.uniform(-25, 25)), 2)}
    count = int(rng.choice([1, 2, 3, 4], p=[0.15, 0.30, 0.30, 0.25]))
    materials = []
    for i in range(count):
        mkind = str(rng.choice([k[0] for k in KINDS], p=[k[1] for k in KINDS]))
        family, bsdf = draw_material_of_kind(rng, mkind)
        materials.append({"name": "m%d_%s" % (i, mkind), "kind": mkind, "family": family, "bsdf": bsdf})
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
    rows, _ = light_rows()
    tint = np.array([1.0, rng.uniform(1.0, 1.3), rng.uniform(1.0, 1.75)])
    level = np.exp(rng.uniform(np.log(0.3), np.log(1.7), len(rows)))
    ints = np.clip(level[:, None] * tint[None] * rng.uniform(0.95, 1.05, (len(rows), 3)), 0.3, 3.0)
    return {"seed": seed, "name": "ps%02d" % seed, "shape": shape, "materials": materials, "true_count": count,
            "blend": blend, "paint_seed": int(rng.integers(2 ** 31)), "wave_seed": int(rng.integers(2 ** 31)),
            "lights": {"directions": DILIGENT_LIGHTS, "tint": np.round(tint, 4).tolist(),
                       "intensities": np.round(ints, 4).tolist()},
            "target_median_255": round(float(rng.uniform(5, 15)), 3),
            "width": WIDTH, "height": HEIGHT, "fill": FILL, "spp": SPP, "aov_spp": AOV_SPP, "max_depth": MAX_DEPTH}


def placed_geometry(params):
    """(v, f): the drawn shape rotated, its projected bounding box centred on the optical axis."""
    v, _, f = ms.geometry(params)
    r = params["shape"]["rotation_deg"]
    v = v @ rotation(r["yaw"], r["pitch"], r["roll"]).T
    lo, hi = v.min(0), v.max(0)
    v = v - np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 0.0])
    return v, f


def _mesh(mi, v, f, w, bsdf):
    """The object as a Mitsuba mesh (Mitsuba's vertex normals) with the blend weights as attributes."""
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    m = mi.Mesh("object", len(v), len(f), props=props, has_vertex_normals=True)
    p = mi.traverse(m)
    p["vertex_positions"] = v.astype(np.float32).ravel().tolist()
    p["faces"] = f.astype(np.uint32).ravel().tolist()
    p.update()
    m.recompute_vertex_normals()
    for name, values in mc.blend_attributes(w):
        m.add_attribute(name, 1, values.astype(np.float32).tolist())
    return m


def to_8bit(x):
    """DiLiGenT's 8-bit copies: 16-bit raw (round, clipped) divided by 256, floored."""
    raw = np.clip(np.round(x * 65535.0), 0, 65535).astype(np.int64)
    return (raw // 256).astype(np.uint8)


def render_object(params, out, log=print):
    """Renders params' object into the folder out (DiLiGenT layout); returns the render seconds."""
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    t0 = time.time()
    rows, dirs = light_rows()
    ints = np.array(params["lights"]["intensities"])
    v, f = placed_geometry(params)
    k = params["true_count"]
    w = ms.weights({"true_count": k, "blend": params["blend"], "seed": params["wave_seed"]}, v,
                   np.random.default_rng(params["paint_seed"]))
    shaded = _mesh(mi, v, f, w, mc.blend_material([m["bsdf"] for m in params["materials"]]))

    half = max(v[:, 0].max() - v[:, 0].min(), v[:, 1].max() - v[:, 1].min()) / 2 / params["fill"]
    T = mi.ScalarTransform4f
    to_world = T().look_at(origin=[0, 0, CAMERA_Z], target=[0, 0, 0], up=[0, 1, 0]) @ T().scale([half, half, 1])

    def sensor(spp, seed):
        return {"type": "orthographic", "to_world": to_world,
                "film": {"type": "hdrfilm", "width": params["width"], "height": params["height"],
                         "rfilter": {"type": "box"}, "pixel_format": "rgba"},
                "sampler": {"type": "independent", "sample_count": spp, "seed": seed}}

    tmp = out.rstrip("/") + ".partial"
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(os.path.join(tmp, "truth"))

    # Mask and normals: alpha and the mean shading normal per pixel.
    aov = mi.load_dict({"type": "scene", "sensor": sensor(params["aov_spp"], params["seed"] * 1000 + 999),
                        "integrator": {"type": "aov", "aovs": "nn:sh_normal", "inner": {"type": "direct"}},
                        "object": shaded})
    mi.render(aov)
    bmp = aov.sensors()[0].film().bitmap()
    names = [c.name for c in bmp.struct_()]
    arr = np.array(bmp, dtype=np.float64)
    alpha = arr[..., names.index("A")]
    nrm = arr[..., [names.index("nn.X"), names.index("nn.Y"), names.index("nn.Z")]]
    mask = alpha >= 0.5
    length = np.linalg.norm(nrm, axis=2, keepdims=True)
    normals = np.where(mask[..., None] & (length > 1e-6), nrm / np.maximum(length, 1e-12), 0.0)
    t_aov = time.time() - t0

    photos = []
    for i, (d, e) in enumerate(zip(dirs, ints)):
        scene = mi.load_dict({
            "type": "scene", "integrator": {"type": "path", "max_depth": params["max_depth"], "hide_emitters": True},
            "sensor": sensor(params["spp"], params["seed"] * 1000 + i), "object": shaded,
            "light": {"type": "directional", "direction": (-d).tolist(), "irradiance": {"type": "rgb",
                                                                                      "value": e.tolist()}}})
        photos.append(np.array(mi.render(scene), dtype=np.float64)[..., :3])
        if (i + 1) % 24 == 0:
            log("  %s: rendered %d/%d photos (%.0f s)" % (params["name"], i + 1, len(dirs), time.time() - t0))
    photos = np.stack(photos)
    grey = photos.mean(axis=3)[:, mask]
    median = float(np.median(grey))
    exposure = params["target_median_255"] / 255.0 / max(median, 1e-12)
    eight = [to_8bit(p * exposure) for p in photos]
    for i, img in enumerate(eight):
        mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(os.path.join(tmp, "%03d.png" % (i + 1)))
    m8 = np.repeat((mask * 255).astype(np.uint8)[..., None], 3, axis=2)
    mi.Bitmap(m8, pixel_format=mi.Bitmap.PixelFormat.RGB).write(os.path.join(tmp, "mask.png"))
    mi.Bitmap(normals.astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(
        os.path.join(tmp, "normal_gt.exr"))
    with open(os.path.join(tmp, "filenames.txt"), "w") as fh:
        fh.write("".join("%03d.png\n" % (i + 1) for i in range(len(dirs))))
    with open(os.path.join(tmp, "light_directions.txt"), "w") as fh:
        fh.write("\n".join(rows) + "\n")
    with open(os.path.join(tmp, "light_intensities.txt"), "w") as fh:
        fh.write("".join("%.4f %.4f %.4f\n" % tuple(e) for e in ints))
    np.save(os.path.join(tmp, "truth", "vertex_weights.npy"), w)
    mc.write_obj(os.path.join(tmp, "truth", "mesh.obj"), v, None, f)

    stack = np.stack(eight)[:, mask]                         # (photos, pixels, 3)
    per_photo_median = np.median(stack.mean(axis=2), axis=1)
    seconds = time.time() - t0
    derived = {"exposure": exposure, "median_radiance_grey": median,
               "median_8bit_grey_all": float(np.median(stack.mean(axis=2))),
               "per_photo_median_8bit_range": [float(per_photo_median.min()), float(per_photo_median.max())],
               "saturated_fraction": float(np.any(stack == 255, axis=2).mean()),
               "zero_fraction": float(np.all(stack == 0, axis=2).mean()),
               "mask_pixels": int(mask.sum()), "normals_facing_away": int((normals[..., 2] < 0).sum()),
               "ortho_half_extent": half, "vertices": len(v), "triangles": len(f),
               "render_s": round(seconds, 1), "aov_s": round(t_aov, 1), "mitsuba": mi.__version__,
               "variant": "scalar_rgb", "sampler_sha256": sampler_hash(),
               "date": datetime.datetime.now().isoformat(timespec="seconds")}
    with open(os.path.join(tmp, "truth", "params.json"), "w") as fh:
        json.dump({"params": params, "derived": derived}, fh, indent=1)
    if os.path.exists(out):
        shutil.rmtree(out)
    os.rename(tmp, out)
    return seconds


def complete(folder):
    if not all(os.path.isfile(os.path.join(folder, n)) for n in FILES):
        return False
    names = [l.strip() for l in open(os.path.join(folder, "filenames.txt")) if l.strip()]
    return len(names) > 0 and all(os.path.isfile(os.path.join(folder, n)) for n in names)


def check_params():
    """A diffuse grey sphere (the frame / sign check), one light level, no tint."""
    p = draw_object(1)
    n = len(p["lights"]["intensities"])
    p.update(name="check_sphere", shape={"kind": "sphere", "detail": 64, "uvs": False,
                                         "rotation_deg": {"yaw": 0, "pitch": 0, "roll": 0}},
             materials=[{"name": "m0_diffuse", "kind": "diffuse", "family": "diffuse",
                         "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}}],
             true_count=1, blend={"kind": "sharp", "border": 0.004}, target_median_255=40.0)
    p["lights"] = dict(p["lights"], tint=[1, 1, 1], intensities=[[1.0, 1.0, 1.0]] * n)
    return p


def check_sphere(folder):
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    s = render_object(check_params(), folder)
    n = np.array(mi.Bitmap(os.path.join(folder, "normal_gt.exr")), dtype=np.float64)[..., :3]
    h, w = n.shape[:2]
    mask = np.linalg.norm(n, axis=2) > 0.5
    cols = np.where(mask[h // 2])[0]
    print("rendered in %.0f s; centre normal %s; rightmost mask pixel (col %d) normal %s; top %s" % (
        s, np.round(n[h // 2, w // 2], 3), cols.max(), np.round(n[h // 2, cols.max()], 3),
        np.round(n[np.where(mask[:, w // 2])[0].min(), w // 2], 3)))
    _, dirs = light_rows()
    imgs = np.stack([np.array(mi.Bitmap(os.path.join(folder, "%03d.png" % (i + 1))), dtype=np.float64)[..., :3]
                     for i in range(len(dirs))]) / 255.0
    i = int(np.argmax(dirs[:, 0]))
    g = imgs[i].mean(axis=2)
    right, left = g[mask & (np.arange(w)[None] > w // 2)].mean(), g[mask & (np.arange(w)[None] < w // 2)].mean()
    print("light %d to_light %s: mean right half %.4f, left half %.4f" % (i + 1, np.round(dirs[i], 3), right, left))
    b = np.einsum("kd,khw->hwd", dirs, imgs.mean(axis=3))
    gvec = b @ np.linalg.inv(dirs.T @ dirs).T
    est = gvec / np.maximum(np.linalg.norm(gvec, axis=2, keepdims=True), 1e-12)
    ang = np.degrees(np.arccos(np.clip((est * n).sum(axis=2), -1, 1)))[mask]
    print("Lambertian LS (all 96 lights, no shadow handling) vs normal_gt: mean %.2f deg, median %.2f deg" % (
        ang.mean(), np.median(ang)))


def parse_seeds(text):
    seeds = []
    for part in text.split(","):
        if "-" in part:
            a, b = part.split("-")
            seeds += list(range(int(a), int(b) + 1))
        elif part:
            seeds.append(int(part))
    return seeds


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", help="e.g. 1-6 or 1,3,5")
    ap.add_argument("--out", help="folder of objects psNN")
    ap.add_argument("--show", type=int, metavar="SEED", help="print SEED's draw")
    ap.add_argument("--check-sphere", metavar="DIR", help="render a diffuse sphere and check frames and signs")
    a = ap.parse_args()
    if a.show is not None:
        print(json.dumps(draw_object(a.show), indent=1))
    elif a.check_sphere:
        check_sphere(a.check_sphere)
    elif a.seeds and a.out:
        os.makedirs(a.out, exist_ok=True)
        total = 0.0
        for seed in parse_seeds(a.seeds):
            params = draw_object(seed)
            folder = os.path.join(a.out, params["name"])
            if complete(folder):
                print("%s: complete, kept" % folder)
                continue
            s = render_object(params, folder, log=lambda m: print(m, flush=True))
            total += s
            print("%s: %s, %s in %.0f s" % (folder, params["shape"].get("name", params["shape"]["kind"]),
                                           ", ".join(m["kind"] for m in params["materials"]), s), flush=True)
        print("rendered in %.0f s in all" % total)
    else:
        ap.error("give --seeds S --out DIR, --show SEED or --check-sphere DIR")


if __name__ == "__main__":
    sys.exit(main())
