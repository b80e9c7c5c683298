#!/usr/bin/env python3
"""Writes a capture in the dataset contract (`svbrdf-scene/1`) rendered by an
independent renderer, Mitsuba 3, so that the reconstruction is measured on
images its own generator did not make (issue 8's "independent captures").

The object (a sphere, a torus, or any OBJ, with or without texture
coordinates) is painted with three materials that Mitsuba models natively and
this project models with its own code:
  metal   roughconductor, GGX, alpha 0.2, copper eta/k (RGB values below)
  plastic roughplastic, GGX, alpha 0.1, ior 1.5, red diffuse base
  paint   diffuse, matte green
mixed per vertex by smooth weights (three regions with soft borders, blended by
nested `blendbsdf`s through mesh attributes, so no texture coordinates are
needed). Point lights (W/sr), one per photo, half of them a flash beside the
lens; shading normals are Mitsuba's own (angle-weighted, as its OBJ and PLY
loaders compute them for a file without normals, so mesh.obj has no vn;
`--normals area` renders and writes area-weighted ones); PINHOLE cameras on a sphere around the object; masks from a coverage pass
(the object as a unit emitter, box filter: pixel value = covered fraction,
kept where >= 0.5). `--bounces N` renders N indirect bounces (interreflection
on the torus); `--noise` adds relative Gaussian noise. Held-out views with
lights never used for fitting go to heldout/scene.json.

Needs the Mitsuba 3 wheel (not a Debian package):
    python3 -m venv /work/scratch/mi && /work/scratch/mi/bin/pip install mitsuba
    /work/scratch/mi/bin/python scripts/mitsuba_capture.py --shape torus --out out/mi_torus
Then: svbrdf reconstruct out/mi_torus/scene.json --out MAT;
      svbrdf relight MAT out/mi_torus/heldout/scene.json --out RELIT;
      svbrdf evaluate RELIT out/mi_torus/heldout/scene.json
(scripts/batch.sh CAPTURES OUT --local runs all three over a folder of such
captures and collects a summary table).
"""
import argparse
import json
import math
import os
import shutil
import sys
import time

import numpy as np

# Copper, RGB (R 650 nm, G 550 nm, B 450 nm) from Johnson & Christy 1972 via
# refractiveindex.info (the same source as lib/brdf/metals.h).
COPPER_ETA = [0.27105, 0.67693, 1.31640]
COPPER_K = [3.60920, 2.62480, 2.29210]
PLASTIC_BASE = [0.55, 0.06, 0.04]
PAINT = [0.10, 0.42, 0.14]


def sphere(detail):
    n_lat, n_lon = detail, 2 * detail
    verts, uvs, faces = [], [], []
    for i in range(n_lat + 1):
        th = math.pi * i / n_lat
        for j in range(n_lon + 1):
            ph = 2 * math.pi * j / n_lon
            verts.append([0.5 * math.sin(th) * math.cos(ph), 0.5 * math.cos(th), -0.5 * math.sin(th) * math.sin(ph)])
            uvs.append([j / n_lon, 1 - i / n_lat])
    w = n_lon + 1
    for i in range(n_lat):
        for j in range(n_lon):
            a, b, c, d = i * w + j, i * w + j + 1, (i + 1) * w + j, (i + 1) * w + j + 1
            if i > 0:
                faces.append([a, c, b])
            if i < n_lat - 1:
                faces.append([b, c, d])
    return np.array(verts), np.array(uvs), np.array(faces)


def torus(detail, big=0.36, small=0.16):
    n_u, n_v = 2 * detail, detail
    verts, uvs, faces = [], [], []
    for i in range(n_u + 1):
        u = 2 * math.pi * i / n_u
        for j in range(n_v + 1):
            v = 2 * math.pi * j / n_v
            r = big + small * math.cos(v)
            verts.append([r * math.cos(u), small * math.sin(v), -r * math.sin(u)])
            uvs.append([i / n_u, j / n_v])
    w = n_v + 1
    for i in range(n_u):
        for j in range(n_v):
            a, b, c, d = i * w + j, i * w + j + 1, (i + 1) * w + j, (i + 1) * w + j + 1
            faces += [[a, c, b], [b, c, d]]  # counter-clockwise seen from outside
    return np.array(verts), np.array(uvs), np.array(faces)


def read_obj(path):
    verts, faces = [], []
    for line in open(path):
        p = line.split()
        if not p:
            continue
        if p[0] == "v":
            verts.append([float(x) for x in p[1:4]])
        elif p[0] == "f":
            idx = [int(x.split("/")[0]) - 1 for x in p[1:]]
            for k in range(1, len(idx) - 1):
                faces.append([idx[0], idx[k], idx[k + 1]])
    return normalize(np.array(verts)), None, np.array(faces)


def normalize(v):
    """Centres a point set's bounding box at the origin and scales it into a ball of radius 0.5."""
    v = v - 0.5 * (v.min(0) + v.max(0))
    return v * (0.5 / np.linalg.norm(v, axis=1).max())


def vertex_normals(v, f):
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # area-weighted
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, f[:, k], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def paint(v, rng, border, regions=3, jitter=None):
    """`regions` regions around well-separated seed vertices (farthest point
    first), soft borders of width ~border metres: weight_i =
    softmax(-distance_i / border). `jitter(v)`, if given, returns a
    (len(v), regions) field in metres added to the distances (noisy borders)."""
    seeds = [v[rng.integers(len(v))]]
    for _ in range(regions - 1):
        d = np.min([np.linalg.norm(v - s, axis=1) for s in seeds], axis=0)
        seeds.append(v[np.argmax(d)])
    d = np.stack([np.linalg.norm(v - s, axis=1) for s in seeds], axis=1)
    if jitter is not None:
        d = d + jitter(v)
    z = -(d - d.min(1, keepdims=True)) / border
    w = np.exp(z)
    return w / w.sum(1, keepdims=True)


def look_at_pose(eye, target, rng):
    """cam_from_world (x right, y down, z forward) looking from eye at target, random roll."""
    z = target - eye
    z /= np.linalg.norm(z)
    up = rng.normal(size=3)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    r = np.stack([x, y, z])  # rows: camera axes in world
    return r, -r @ eye


def quat(r):
    w = math.sqrt(max(0.0, 1 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    x = math.sqrt(max(0.0, 1 + r[0, 0] - r[1, 1] - r[2, 2])) / 2
    y = math.sqrt(max(0.0, 1 - r[0, 0] + r[1, 1] - r[2, 2])) / 2
    z = math.sqrt(max(0.0, 1 - r[0, 0] - r[1, 1] + r[2, 2])) / 2
    x = math.copysign(x, r[2, 1] - r[1, 2])
    y = math.copysign(y, r[0, 2] - r[2, 0])
    z = math.copysign(z, r[1, 0] - r[0, 1])
    q = np.array([w, x, y, z])
    return (q / np.linalg.norm(q)).tolist()


def write_obj(path, v, uv, f, normals=None):
    """OBJ with optional texture coordinates and per-position normals (vn)."""
    with open(path, "w") as out:
        out.write("# mitsuba_capture.py mesh\n")
        for p in v:
            out.write("v %.9g %.9g %.9g\n" % tuple(p))
        if uv is not None:
            for t in uv:
                out.write("vt %.9g %.9g\n" % tuple(t))
        if normals is not None:
            for n in normals:
                out.write("vn %.9g %.9g %.9g\n" % tuple(n))
        for t in f + 1:
            corners = []
            for i in t:
                c = "%d" % i
                if uv is not None or normals is not None:
                    c += "/%d" % i if uv is not None else "/"
                if normals is not None:
                    c += "/%d" % i
                corners.append(c)
            out.write("f %s\n" % " ".join(corners))


def fixed_materials():
    """The three materials of this script's captures: (name, Mitsuba BSDF dict)."""
    metal = {"type": "roughconductor", "distribution": "ggx", "alpha": 0.2,
             "eta": {"type": "rgb", "value": COPPER_ETA}, "k": {"type": "rgb", "value": COPPER_K}}
    plastic = {"type": "roughplastic", "distribution": "ggx", "alpha": 0.1, "int_ior": 1.5, "ext_ior": 1.0,
               "diffuse_reflectance": {"type": "rgb", "value": PLASTIC_BASE}, "nonlinear": False}
    paint_bsdf = {"type": "diffuse", "reflectance": {"type": "rgb", "value": PAINT}}
    return [("metal", metal), ("plastic", plastic), ("paint", paint_bsdf)]


def blend_material(bsdfs):
    """Nested `blendbsdf`s mixing the BSDF dicts by per-vertex weights: level i
    blends bsdfs[i] with the rest by the attribute vertex_blend<i> (see
    blend_attributes). One BSDF needs no blend."""
    def level(i):
        if i == len(bsdfs) - 1:
            return bsdfs[i]
        return {"type": "blendbsdf", "weight": {"type": "mesh_attribute", "name": "vertex_blend%d" % i},
                "bsdf_0": bsdfs[i], "bsdf_1": level(i + 1)}
    return level(0)


def blend_attributes(w):
    """Per-vertex weights (n, k) -> the k - 1 attributes of blend_material:
    blend<i> = (w_i+1 + ... + w_k-1) / (w_i + ... + w_k-1), the share of the
    later materials among those not taken by the earlier levels."""
    attrs, prev = [], None
    for i in range(w.shape[1] - 1):
        rest = w[:, i + 1:].sum(1)
        attrs.append(("vertex_blend%d" % i, rest if prev is None else rest / np.maximum(prev, 1e-9)))
        prev = rest
    return attrs


def camera_side_dir(rng, eye):
    """A random unit direction on the camera's side of the object."""
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    return -d if d @ eye < 0 else d


def alternate_flash(k, held):
    """This script's light plan: odd training photos take a flash, the rest a lamp."""
    return "flash" if (k % 2 == 1) and not held else "point"


def render_capture(out, v, uv, f, w, materials, rng, *, views=40, heldout=8, width=320, height=240, spp=32,
                   bounces=0, noise=0.01, seed=7, normals="mitsuba", light_kind=alternate_flash,
                   point_intensity=10.0, flash_intensity=6.0, directional_irradiance=1.6, camera_distance=2.2,
                   light_distance=2.5, ceiling_spp=0, truth_extra=None, truth_files=None, log=print):
    """Renders a capture of mesh (v, uv, f) painted with `materials` [(name,
    Mitsuba BSDF dict)] mixed by per-vertex weights w (n, len(materials)) into
    the folder `out` (dataset contract, held-out views in heldout/, truth/).

    Per photo k (views + heldout of them): a camera on a sphere of radius
    camera_distance looking at the origin, and a light of kind
    light_kind(k, held): "point" (a lamp at light_distance on the camera's side,
    W/sr), "flash" (a point light beside the lens, in the camera frame) or
    "directional" (from the camera's side). rng draws poses, lights and the
    relative noise. ceiling_spp > 0 renders every held-out view once more with
    an independent sampler seed and no added noise into truth/ceiling/ (the
    truth's own relight, for a ceiling). truth_files: {name: JSON object}
    written into truth/. Returns the seconds taken."""
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    t0 = time.time()
    n = vertex_normals(v, f)
    tmp = out.rstrip("/") + ".partial"
    shutil.rmtree(tmp, ignore_errors=True)
    for d in ("images", "masks", "heldout/images", "heldout/masks", "truth"):
        os.makedirs(os.path.join(tmp, d))
    if ceiling_spp:
        os.makedirs(os.path.join(tmp, "truth", "ceiling", "images"))
    # Without normals when Mitsuba computes its own (a reader computes the
    # same angle-weighted ones); with them (vn) when they are this script's.
    write_obj(os.path.join(tmp, "mesh.obj"), v, uv, f, n if normals == "area" else None)
    np.save(os.path.join(tmp, "truth", "vertex_weights.npy"), w)
    material = blend_material([b for _, b in materials])

    def painted_mesh(bsdf, emitter=None):
        """The object as a Mitsuba mesh with the blend weights as vertex attributes."""
        props = mi.Properties()
        props["bsdf"] = mi.load_dict(bsdf)
        if emitter is not None:
            props["emitter"] = mi.load_dict(emitter)
        m = mi.Mesh("object", len(v), len(f), props=props, has_vertex_normals=True)
        p = mi.traverse(m)
        p["vertex_positions"] = v.astype(np.float32).ravel().tolist()
        p["vertex_normals"] = n.astype(np.float32).ravel().tolist()
        p["faces"] = f.astype(np.uint32).ravel().tolist()
        p.update()
        if normals == "mitsuba":
            m.recompute_vertex_normals()
        for name, values in blend_attributes(w):
            m.add_attribute(name, 1, values.astype(np.float32).tolist())
        return m

    shaded = painted_mesh(material)
    coverage_mesh = painted_mesh({"type": "diffuse", "reflectance": 0.0}, {"type": "area", "radiance": 1.0})

    fx = 1.2 * width
    cx, cy = width / 2, height / 2
    fov = math.degrees(2 * math.atan(width / 2 / fx))
    flash_offset = np.array([0.06, -0.04, 0.0])
    total = views + heldout

    def sample_dir():
        d = rng.normal(size=3)
        return d / np.linalg.norm(d)

    sets = {"": {"lights": [], "images": []}, "heldout": {"lights": [], "images": []}}
    for k in range(total):
        held = k >= views
        s = sets["heldout" if held else ""]
        idx = len(s["images"])
        eye = camera_distance * sample_dir()
        r, t = look_at_pose(eye, np.zeros(3), rng)
        kind = light_kind(k, held)
        if kind == "flash":
            light_world = eye + r.T @ flash_offset
            light = {"id": idx + 1, "type": "point", "frame": "camera", "position": flash_offset.tolist(),
                     "intensity": [flash_intensity] * 3}
            mi_light = {"type": "point", "position": light_world.tolist(),
                        "intensity": {"type": "rgb", "value": [flash_intensity] * 3}}
        elif kind == "point":
            # A lamp on the camera's side of the object, so the view sees lit surface.
            light_world = light_distance * camera_side_dir(rng, eye)
            light = {"id": idx + 1, "type": "point", "position": light_world.tolist(),
                     "intensity": [point_intensity] * 3}
            mi_light = {"type": "point", "position": light_world.tolist(),
                        "intensity": {"type": "rgb", "value": [point_intensity] * 3}}
        elif kind == "directional":
            to_light = camera_side_dir(rng, eye)
            light = {"id": idx + 1, "type": "directional", "to_light": to_light.tolist(),
                     "irradiance": [directional_irradiance] * 3}
            mi_light = {"type": "directional", "direction": (-to_light).tolist(),
                        "irradiance": {"type": "rgb", "value": [directional_irradiance] * 3}}
        else:
            raise ValueError("unknown light kind %r" % kind)
        s["lights"].append(light)
        name = "images/%04d.exr" % idx
        s["images"].append({"file": name, "camera": 1, "light": idx + 1,
                            "cam_from_world": {"q": quat(r), "t": t.tolist()}, "exposure": 1.0,
                            "mask": "masks/%04d.png" % idx})

        # Mitsuba's camera frame is x left, y up, z forward: ours turned 180 deg about z.
        world_from_cam = np.eye(4)
        world_from_cam[:3, :3] = r.T @ np.diag([-1.0, -1.0, 1.0])
        world_from_cam[:3, 3] = eye
        sensor = {"type": "perspective", "fov": fov, "fov_axis": "x",
                  "to_world": mi.ScalarTransform4f(world_from_cam.tolist()),
                  "film": {"type": "hdrfilm", "width": width, "height": height,
                           "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                  "sampler": {"type": "independent", "sample_count": spp, "seed": seed * 1000 + k}}

        def render(sensor):
            scene = mi.load_dict({
                "type": "scene",
                "integrator": {"type": "path", "max_depth": bounces + 2, "hide_emitters": True},
                "sensor": sensor, "light": mi_light, "object": shaded,
            })
            return np.array(mi.render(scene), dtype=np.float64)[:, :, :3]

        img = render(sensor)
        if noise > 0:
            img *= 1 + noise * rng.normal(size=img.shape)
        img = np.maximum(img, 0).astype(np.float32)
        cover_sensor = dict(sensor)
        cover_sensor["sampler"] = {"type": "independent", "sample_count": 16, "seed": k}
        cover = mi.load_dict({
            "type": "scene", "integrator": {"type": "direct"}, "sensor": cover_sensor,
            "object": coverage_mesh,
        })
        coverage = np.array(mi.render(cover))[:, :, 0]
        mask = np.where(coverage >= 0.5, 255, 0).astype(np.uint8)
        folder = os.path.join(tmp, "heldout") if held else tmp
        mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(os.path.join(folder, name))
        mi.Bitmap(mask, pixel_format=mi.Bitmap.PixelFormat.Y).write(os.path.join(folder, "masks/%04d.png" % idx))
        if held and ceiling_spp:
            # The truth rendered again: an independent seed, no added noise.
            again = dict(sensor)
            again["sampler"] = {"type": "independent", "sample_count": ceiling_spp, "seed": 10 ** 6 + seed * 1000 + k}
            mi.Bitmap(render(again).astype(np.float32), pixel_format=mi.Bitmap.PixelFormat.RGB).write(
                os.path.join(tmp, "truth", "ceiling", name))
        log("  rendered %s%s  (%d/%d, %.0f s)" % ("heldout/" if held else "", name, k + 1, total, time.time() - t0))

    camera = {"id": 1, "model": "PINHOLE", "width": width, "height": height, "params": [fx, fx, cx, cy]}
    truth = {"renderer": "mitsuba %s scalar_rgb, path max_depth %d, %d spp" % (mi.__version__, bounces + 2, spp),
             "materials": dict(materials),
             "vertex_weights": "truth/vertex_weights.npy (%s per vertex of mesh.obj)" % ", ".join(
                 name for name, _ in materials),
             "heldout_scene": "heldout/scene.json"}
    if ceiling_spp:
        truth["ceiling"] = ("truth/ceiling/: the held-out views rendered again by Mitsuba (%d spp, independent "
                            "seed, no added noise)" % ceiling_spp)
    truth.update(truth_extra or {})
    for key, s in sets.items():
        doc = {"format": "svbrdf-scene/1", "mesh": "mesh.obj" if key == "" else "../mesh.obj",
               "images_color_space": "linear", "cameras": [camera], "lights": s["lights"], "images": s["images"]}
        if key == "":
            doc["ground_truth"] = truth
        with open(os.path.join(tmp, key, "scene.json"), "w") as out_file:
            json.dump(doc, out_file, indent=1)
    for name, obj in (truth_files or {}).items():
        with open(os.path.join(tmp, "truth", name), "w") as out_file:
            json.dump(obj, out_file, indent=1)
    if os.path.exists(out):
        shutil.rmtree(out)
    os.rename(tmp, out)
    return time.time() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shape", default="sphere", help="sphere | torus | path to an OBJ (its UVs are dropped)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--views", type=int, default=40)
    ap.add_argument("--heldout", type=int, default=8)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--bounces", type=int, default=0, help="indirect bounces (0 = direct light only)")
    ap.add_argument("--noise", type=float, default=0.01, help="relative Gaussian noise per pixel")
    ap.add_argument("--border", type=float, default=0.02, help="soft border width between materials (m)")
    ap.add_argument("--no-uvs", action="store_true", help="write the mesh without texture coordinates")
    ap.add_argument("--detail", type=int, default=64)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--normals", choices=["mitsuba", "area"], default="mitsuba",
                    help="shading normals: Mitsuba's own (recompute_vertex_normals, angle-weighted, as its OBJ and "
                         "PLY loaders compute them for a file without normals) or area-weighted")
    args = ap.parse_args()

    rng = np.random.default_rng(args.seed)
    if args.shape == "sphere":
        v, uv, f = sphere(args.detail)
    elif args.shape == "torus":
        v, uv, f = torus(args.detail)
    else:
        v, uv, f = read_obj(args.shape)
    if args.no_uvs:
        uv = None
    w = paint(v, rng, args.border)
    seconds = render_capture(args.out, v, uv, f, w, fixed_materials(), rng, views=args.views, heldout=args.heldout,
                             width=args.width, height=args.height, spp=args.spp, bounces=args.bounces,
                             noise=args.noise, seed=args.seed, normals=args.normals,
                             truth_extra={"options": vars(args)}, log=lambda m: print(m, flush=True))
    print("capture: %s/scene.json (%d views, %d held out) in %.0f s" % (args.out, args.views, args.heldout, seconds))


if __name__ == "__main__":
    sys.exit(main())
