#!/usr/bin/python3
"""Benchmark on real photographs: three objects of DiLiGenT (ball, cat, pot1; 96 directional lights).

Protocol (per object): lights 6, 12, ..., 96 are held out (16 photos), the other 80 are the training
capture. Four ways to predict the held-out photos, all scored by one function (`svbrdf evaluate`:
mean over the held-out photos of the sRGB PSNR inside each photo's mask, after dividing by its
exposure and clamping to [0, 1]; lib/evaluate/metrics.cc):

  project_with_normals       svbrdf import-ps --normals normal_gt.exr, reconstruct, relight
  project_estimated_normals  svbrdf import-ps --truth-normals normal_gt.exr (normals estimated by
                             the project, the truth only scored), reconstruct, relight
  lambert_peer               per-pixel Lambertian albedo by least squares with the TRUE normals over
                             the training photos (each divided by exposure x irradiance; only pixels
                             valid in that photo's mask and not saturated; n.l <= 0 excluded);
                             predicts exposure x irradiance x albedo/pi x max(0, n.l)
  interpolation_peer         each held-out photo = the 3 training photos whose lights are nearest in
                             angle, each divided by exposure x irradiance, blended with weights
                             1 / (angular distance), times the held-out exposure x irradiance; a
                             pixel invalid in one of the 3 (saturated / outside its mask) is left out
                             of that pixel's blend; if all 3 are invalid the nearest training photo
                             valid there is used

The peers read the capture folders that `svbrdf import-ps` writes (scene.json, heldout/scene.json),
so their inputs (photos, masks, exposures, lights) are the project's, and they write linear images
laid out like `svbrdf relight` output (same relative file names as heldout/scene.json's images:
float EXR where the name ends in .exr, 16-bit PNG/TIFF where it ends in .png/.tif, as import-ps
names the copied photos). The peers' PSNR is also computed in Python with the definition of
metrics.cc, as a cross-check of `svbrdf evaluate`.

--peers-only needs no CLI: the split is built by a Python stand-in for import-ps (per-photo mask =
mask.png minus pixels with a channel at 255, for held-out photos also eroded twice by 4-neighbour
erosion, as import-ps does by default;
exposure from --peers-exposure; irradiance = light_intensities.txt; to_light = (lx, -ly, -lz) in the
COLMAP camera frame) and scored in Python only. Note that the sRGB PSNR depends on the exposure: the photos are dark (median
3-16 of 255), and an exposure that brightens them k times lowers every method's PSNR.

Outputs OUT.json, OUT.md (tables + protocol), OUT.png (PSNR bar chart) and OUT_<object>.png (one
held-out light: photo / relit / |error|, estimated vs true normals); OUT defaults to
bench_results/diligent. Intermediate captures, materials and renders go to --work.

Usage: /usr/bin/python3 scripts/bench_diligent.py [--data /work/shared/data/diligent]
         [--objects ball,cat,pot1] [--cli build/apps/svbrdf] [--work /tmp/diligent_bench]
         [--out bench_results/diligent] [--peers-only [--peers-exposure 1|pNN]]
Run niced, e.g. `nice -n 5 /usr/bin/python3 scripts/bench_diligent.py`.
"""
import argparse
import datetime
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

import cv2
import numpy as np
import OpenImageIO as oiio

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

METHODS = ["project_with_normals", "project_estimated_normals", "lambert_peer", "interpolation_peer"]
METHOD_LABELS = {
    "project_with_normals": "project, true normals",
    "project_estimated_normals": "project, estimated normals",
    "lambert_peer": "Lambert peer (true normals)",
    "interpolation_peer": "3-nearest-light interpolation",
}
# Published mean angular errors (deg) from /work/shared/data/diligent/README.md (96 lights, 16-bit
# originals) and that README's own measurement of Lambertian least squares on these 8-bit copies.
PUBLISHED_NORMALS = {
    "Lambertian least squares (Woodham 1980)": {"ball": 4.10, "cat": 8.41, "pot1": 8.89},
    "Alldrin et al. 2008": {"ball": 2.71, "cat": 6.53, "pot1": 7.23},
    "Shi et al. 2014 (ST14)": {"ball": 1.74, "cat": 6.12, "pot1": 6.51},
    "Hui & Sankaranarayanan 2017": {"ball": 1.33, "cat": 4.88, "pot1": 5.16},
    "Lambertian LS on the 8-bit copies (data README)": {"ball": 4.61, "cat": 8.77, "pot1": 10.08},
}


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench import StepError, run  # noqa: E402  (the CLI runner with logs and peak RSS)


# ----------------------------------------------------------------------------------------------
# Images (the conventions of lib/io/image.cc)


def srgb_to_linear(v):
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(v):
    """LinearToSrgb of lib/io/image.cc, in float32 as there."""
    v = np.asarray(v, dtype=np.float32)
    return np.where(v <= np.float32(0.0031308), v * np.float32(12.92),
                    np.float32(1.055) * np.power(v, np.float32(1.0 / 2.4)) - np.float32(0.055)).astype(np.float32)


def read_image(path, space="linear"):
    """As ReadImage: float32 (H, W, C), integer formats normalised to [0, 1], sRGB decoded for
    non-float files if `space` is srgb. Returns (pixels, saturation_level)."""
    inp = oiio.ImageInput.open(path)
    if not inp:
        raise StepError(f"{path}: cannot read image: {oiio.geterror()}")
    spec = inp.spec()
    px = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
    inp.close()
    if px is None:
        raise StepError(f"{path}: cannot read pixels")
    img = np.asarray(px, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    is_float = spec.format.basetype in (oiio.FLOAT, oiio.HALF, oiio.DOUBLE)
    ext = os.path.splitext(path)[1].lower()
    if space == "srgb" and not is_float and ext not in (".exr", ".hdr"):
        ch = [c for c in range(spec.nchannels) if c != spec.alpha_channel]
        img[..., ch] = srgb_to_linear(img[..., ch])
    return img, (math.inf if is_float else 1.0)


def rgb(img):
    """The first three channels (a grey image repeated), as CompareImages reads them."""
    return np.stack([img[..., min(c, img.shape[2] - 1)] for c in range(3)], axis=2)


def write_image(path, img, space="linear"):
    """Writes a rendered image under the file name a scene entry gives: float EXR for .exr (what the
    peers normally write), 16-bit PNG/TIFF (linear, or sRGB-encoded for an srgb scene) otherwise."""
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    h, w, c = img.shape
    ext = os.path.splitext(path)[1].lower()
    if ext in (".exr", ".hdr"):
        spec = oiio.ImageSpec(w, h, c, oiio.FLOAT)
        data = np.ascontiguousarray(img, dtype=np.float32)
        if ext == ".exr":
            spec.attribute("compression", "zip")
    elif ext in (".png", ".tif", ".tiff"):
        spec = oiio.ImageSpec(w, h, c, oiio.UINT16)
        v = np.clip(img, 0, 1)
        if space == "srgb":
            v = linear_to_srgb(v)
        data = np.ascontiguousarray(np.round(v * 65535).astype(np.uint16))
    else:
        raise StepError(f"{path}: the peers write EXR, PNG or TIFF, not {ext}")
    out = oiio.ImageOutput.create(path)
    if not out or not out.open(path, spec):
        raise StepError(f"{path}: cannot write: {oiio.geterror()}")
    ok = out.write_image(data)
    out.close()
    if not ok:
        raise StepError(f"{path}: cannot write pixels")


def read_normals(path):
    n, _ = read_image(path)
    return n[..., :3].astype(np.float64)


# ----------------------------------------------------------------------------------------------
# Scenes


def load_scene(path):
    """The parts of an svbrdf-scene/1 file that a fixed-camera directional-light capture uses."""
    try:
        s = json.load(open(path))
    except (OSError, ValueError) as e:
        raise StepError(f"{path}: {e}")
    base = os.path.dirname(os.path.abspath(path))
    lights = {l["id"]: l for l in s.get("lights", [])}
    entries = []
    for e in s["images"]:
        light = lights.get(e["light"])
        if light is None or light.get("type") != "directional":
            raise StepError(f"{path}: image {e['file']}: light {e['light']} is not a directional light")
        d = np.asarray(light["to_light"], dtype=np.float64)
        entries.append({
            "file": e["file"], "path": os.path.join(base, e["file"]),
            "mask": os.path.join(base, e["mask"]) if e.get("mask") else None,
            "exposure": float(e.get("exposure", 1.0)), "light": e["light"],
            "to_light": d / np.linalg.norm(d), "irradiance": np.asarray(light["irradiance"], dtype=np.float64),
        })
    return {"path": path, "base": base, "space": s.get("images_color_space", "linear"), "entries": entries}


def load_entry(entry, space):
    """(photo as RGB float64, valid mask): inside the entry's mask, finite and below saturation."""
    img, sat = read_image(entry["path"], space)
    valid = np.all(np.isfinite(img), axis=2)
    if math.isfinite(sat):
        valid &= np.all(img < sat, axis=2)
    if entry["mask"]:
        m, _ = read_image(entry["mask"])
        if m.shape[:2] != img.shape[:2]:
            raise StepError(f"{entry['mask']}: {m.shape[1]}x{m.shape[0]} but {entry['path']} is "
                            f"{img.shape[1]}x{img.shape[0]}")
        valid &= m[..., 0] > 0
    return rgb(img).astype(np.float64), valid


# ----------------------------------------------------------------------------------------------
# Scoring: CompareToScene of lib/evaluate/metrics.cc


def compare_images(ref, test, mask, exposure):
    """CompareImages: sRGB PSNR (peak 1) and relative linear RMSE inside mask (channel 0 > 0)."""
    sel = np.ones(ref.shape[:2], bool) if mask is None else mask[..., 0] > 0
    a = rgb(ref)[sel].astype(np.float64) / exposure
    b = rgb(test)[sel].astype(np.float64) / exposure
    ea = linear_to_srgb(np.clip(a, 0, 1).astype(np.float32)).astype(np.float64)
    eb = linear_to_srgb(np.clip(b, 0, 1).astype(np.float32)).astype(np.float64)
    n = int(sel.sum())
    mse = ((ea - eb) ** 2).sum() / (3.0 * n) if n else 0.0
    ref_lin = (a * a).sum()
    return {"psnr_db": 10 * math.log10(1.0 / max(mse, 1e-12)),
            "rel_rmse": math.sqrt(((a - b) ** 2).sum() / ref_lin) if ref_lin > 0 else 0.0, "pixels": n}


def evaluate_py(scene_path, rendered_dir):
    sc = load_scene(scene_path)
    per = []
    for e in sc["entries"]:
        ref, _ = read_image(e["path"], sc["space"])
        test, _ = read_image(os.path.join(rendered_dir, e["file"]), sc["space"])
        mask = read_image(e["mask"])[0] if e["mask"] else None
        if test.shape[:2] != ref.shape[:2]:
            raise StepError(f"{rendered_dir}/{e['file']}: size differs from {e['path']}")
        m = compare_images(ref, test, mask, e["exposure"])
        m["image"] = e["file"]
        per.append(m)
    ps = [m["psnr_db"] for m in per]
    return {"psnr_mean_db": float(np.mean(ps)), "psnr_min_db": float(np.min(ps)),
            "rel_rmse_mean": float(np.mean([m["rel_rmse"] for m in per])), "images": len(per), "per_image": per}


def parse_evaluate(text):
    per_image = []
    for m in re.finditer(r"^(\S+)\s+PSNR\s+([-\d.inf]+) dB\s+rel\. RMSE\s+([-\d.einf]+)", text, re.M):
        per_image.append({"image": m.group(1), "psnr_db": float(m.group(2)), "rel_rmse": float(m.group(3))})
    m = re.search(r"mean PSNR ([-\d.inf]+) dB \(min ([-\d.inf]+)\), mean rel\. RMSE ([-\d.einf]+) over (\d+) images",
                  text)
    if not m:
        raise StepError("cannot parse `svbrdf evaluate` output: " + text[-300:])
    return {"psnr_mean_db": float(m.group(1)), "psnr_min_db": float(m.group(2)), "rel_rmse_mean": float(m.group(3)),
            "images": int(m.group(4)), "per_image": per_image}


# ----------------------------------------------------------------------------------------------
# Peers (read a capture written by import-ps; write images laid out like `svbrdf relight` output)


def world_normals(normals_diligent):
    """DiLiGenT frame (x right, y up, z towards the camera) -> COLMAP camera frame (y down, z away)."""
    return normals_diligent * np.array([1.0, -1.0, -1.0])


def lambert_peer(train_scene, heldout_scene, normals_diligent, out_dir):
    """Per-pixel Lambertian albedo from the true normals; returns a small info dict."""
    tr, ho = load_scene(train_scene), load_scene(heldout_scene)
    n = world_normals(normals_diligent)
    has_n = np.linalg.norm(n, axis=2) > 0.5
    num = den = None
    for e in tr["entries"]:
        img, valid = load_entry(e, tr["space"])
        if img.shape[:2] != n.shape[:2]:
            raise StepError(f"{e['path']}: {img.shape[1]}x{img.shape[0]} but the normals are {n.shape[1]}x{n.shape[0]}")
        s = n @ e["to_light"]                                  # n.l
        w = (valid & has_n & (s > 0)).astype(np.float64)
        v = img / (e["exposure"] * e["irradiance"])            # = albedo/pi * n.l
        if num is None:
            num, den = np.zeros_like(v), np.zeros(s.shape)
        num += (w * s)[..., None] * v
        den += w * s * s
    rho = num / np.maximum(den, 1e-12)[..., None]              # albedo / pi
    rho[den <= 0] = 0
    for e in ho["entries"]:
        s = np.maximum(n @ e["to_light"], 0)
        write_image(os.path.join(out_dir, e["file"]), (rho * s[..., None]) * (e["exposure"] * e["irradiance"]),
                    ho["space"])
    return {"albedo_pixels": int((den > 0).sum()), "albedo_mean": (np.pi * rho[den > 0]).mean(axis=0).tolist()}


def interpolation_peer(train_scene, heldout_scene, out_dir, k=3):
    tr, ho = load_scene(train_scene), load_scene(heldout_scene)
    dirs = np.stack([e["to_light"] for e in tr["entries"]])
    cache = {}

    def normalised(i):
        if i not in cache:
            e = tr["entries"][i]
            img, valid = load_entry(e, tr["space"])
            cache[i] = (img / (e["exposure"] * e["irradiance"]), valid)
        return cache[i]

    fallback_px = 0
    for e in ho["entries"]:
        ang = np.arccos(np.clip(dirs @ e["to_light"], -1, 1))
        order = np.argsort(ang, kind="stable")
        acc = wsum = None
        for i in order[:k]:
            v, valid = normalised(i)
            w = 1.0 / max(ang[i], 1e-6) * valid
            if acc is None:
                acc, wsum = np.zeros_like(v), np.zeros(w.shape)
            acc += w[..., None] * v
            wsum += w
        pred = acc / np.maximum(wsum, 1e-300)[..., None]
        missing = wsum <= 0
        for i in order[k:]:                                    # all k invalid: nearest valid photo
            if not missing.any():
                break
            v, valid = normalised(i)
            use = missing & valid
            pred[use] = v[use]
            missing &= ~use
            fallback_px += int(use.sum())
        pred[missing] = 0
        write_image(os.path.join(out_dir, e["file"]), pred * (e["exposure"] * e["irradiance"]), ho["space"])
    return {"k": k, "weights": "1/angular distance", "fallback_pixels": fallback_px}


def lambertian_ls_normals(scene_path):
    """Woodham least squares over a capture's photos (grey = mean of the normalised channels, only
    valid pixels); unit normals in the DiLiGenT frame."""
    sc = load_scene(scene_path)
    A = b = None
    for e in sc["entries"]:
        img, valid = load_entry(e, sc["space"])
        v = (img / (e["exposure"] * e["irradiance"])).mean(axis=2) * valid
        l = e["to_light"]
        if A is None:
            A, b = np.zeros(v.shape + (3, 3)), np.zeros(v.shape + (3,))
        A += valid[..., None, None] * np.outer(l, l)
        b += v[..., None] * l
    ok = np.linalg.det(A) > 1e-9
    g = np.zeros_like(b)
    g[ok] = np.linalg.solve(A[ok], b[ok][..., None])[..., 0]
    norm = np.linalg.norm(g, axis=2, keepdims=True)
    n = np.where(norm > 0, g / np.maximum(norm, 1e-300), 0)
    return n * np.array([1.0, -1.0, -1.0])


def lambertian_ls_diligent(dlg):
    """Plain Woodham least squares over all photos of a DiLiGenT folder (every pixel, no shadow or
    saturation handling): reproduces the data README's 8-bit row, a check of frames and loading."""
    A, b = np.zeros(dlg["mask"].shape + (3, 3)), np.zeros(dlg["mask"].shape + (3,))
    for name, l, e in zip(dlg["names"], dlg["dirs"], dlg["intensities"]):
        img = cv2.imread(os.path.join(dlg["folder"], name), cv2.IMREAD_UNCHANGED)
        if img is None:
            raise StepError(f"{dlg['folder']}/{name}: cannot read")
        v = (img[..., ::-1] / 255.0 / e).mean(axis=2)
        A += np.outer(l, l)
        b += v[..., None] * l
    g = np.linalg.solve(A.reshape(-1, 3, 3), b.reshape(-1, 3, 1)).reshape(b.shape)
    return g / np.maximum(np.linalg.norm(g, axis=2, keepdims=True), 1e-300)


def angular_error(est, gt, mask):
    """Mean angular error (deg) over mask & true normal present; pixels without an estimate are
    left out and counted in `coverage`."""
    inside = mask & (np.linalg.norm(gt, axis=2) > 0.5)
    has = inside & (np.linalg.norm(est, axis=2) > 0.5)
    a = est[has] / np.linalg.norm(est[has], axis=1, keepdims=True)
    t = gt[has] / np.linalg.norm(gt[has], axis=1, keepdims=True)
    deg = np.degrees(np.arccos(np.clip((a * t).sum(axis=1), -1, 1)))
    return {"mean_deg": float(deg.mean()) if deg.size else None,
            "median_deg": float(np.median(deg)) if deg.size else None,
            "coverage": float(has.sum() / max(inside.sum(), 1))}


# ----------------------------------------------------------------------------------------------
# DiLiGenT folder and the Python stand-in for import-ps (--peers-only)


def load_diligent(folder):
    names = [l.strip() for l in open(os.path.join(folder, "filenames.txt")) if l.strip()]
    dirs = np.loadtxt(os.path.join(folder, "light_directions.txt")).reshape(-1, 3)
    ints = np.loadtxt(os.path.join(folder, "light_intensities.txt")).reshape(-1, 3)
    if not (len(names) == len(dirs) == len(ints)):
        raise StepError(f"{folder}: {len(names)} file names, {len(dirs)} directions, {len(ints)} intensities")
    mask = cv2.imread(os.path.join(folder, "mask.png"), cv2.IMREAD_GRAYSCALE)
    if mask is None:
        raise StepError(f"{folder}/mask.png: cannot read")
    return {"folder": folder, "names": names, "dirs": dirs, "intensities": ints, "mask": mask > 0,
            "normals": read_normals(os.path.join(folder, "normal_gt.exr"))}


def erode(mask, px):
    """As import-ps: px passes of 4-neighbour erosion (pixels on the image border count as edge)."""
    if px <= 0:
        return mask
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    return cv2.erode(mask.astype(np.uint8), cross, iterations=px, borderType=cv2.BORDER_CONSTANT, borderValue=0) > 0


def dequantized_floor(img8):
    """As import-ps --quantization floor: a floored count k >= 1 stored at k + 1/2 as 16-bit PNG
    (round((k + 1/2) * 257)); 0 stays 0, 255 stays saturated."""
    k = img8.astype(np.float64)
    return np.where(k >= 255, 65535, np.where(k > 0, np.round((k + 0.5) * 257), 0)).astype(np.uint16)


def python_import(dlg, out, hold_out_every=6, erode_px=2, erode_training_px=0, exposure_rule="1",
                  quantization="floor"):
    """Writes out/scene.json and out/heldout/scene.json as import-ps is specified to (but with this
    script's own choices for masks and exposure)."""
    if os.path.exists(out):
        shutil.rmtree(out)
    photos = []
    for name in dlg["names"]:
        img = cv2.imread(os.path.join(dlg["folder"], name), cv2.IMREAD_UNCHANGED)
        if img is None or img.dtype != np.uint8:
            raise StepError(f"{dlg['folder']}/{name}: cannot read as 8-bit")
        photos.append(img)
    h, w = photos[0].shape[:2]
    eroded_held, eroded_train = erode(dlg["mask"], erode_px), erode(dlg["mask"], erode_training_px)
    idx = np.arange(1, len(photos) + 1)
    train = idx % hold_out_every != 0
    if exposure_rule.startswith("p"):
        q = float(exposure_rule[1:])
        vals = np.concatenate([photos[i][eroded_train].ravel() for i in np.where(train)[0]]) / 255.0
        exposure = float(np.percentile(vals, q))
    else:
        exposure = float(exposure_rule)
    camera = {"id": 1, "model": "ORTHOGRAPHIC", "width": w, "height": h, "params": [1000.0, 1000.0, w / 2, h / 2]}
    for sub, sel in (("", train), ("heldout", ~train)):
        folder = os.path.join(out, sub)
        os.makedirs(os.path.join(folder, "images"), exist_ok=True)
        os.makedirs(os.path.join(folder, "masks"), exist_ok=True)
        images, lights = [], []
        for i in np.where(sel)[0]:
            stem = os.path.splitext(dlg["names"][i])[0]
            if quantization == "floor":
                cv2.imwrite(os.path.join(folder, "images", stem + ".png"), dequantized_floor(photos[i]))
            else:
                shutil.copyfile(os.path.join(dlg["folder"], dlg["names"][i]), os.path.join(folder, "images", stem + ".png"))
            m = (eroded_held if sub else eroded_train) & np.all(photos[i] < 255, axis=2)
            cv2.imwrite(os.path.join(folder, "masks", stem + ".png"), m.astype(np.uint8) * 255)
            lx, ly, lz = dlg["dirs"][i]
            lights.append({"id": int(i + 1), "type": "directional", "to_light": [float(lx), float(-ly), float(-lz)],
                           "irradiance": [float(x) for x in dlg["intensities"][i]]})
            images.append({"file": f"images/{stem}.png", "camera": 1, "light": int(i + 1),
                           "cam_from_world": {"q": [1.0, 0.0, 0.0, 0.0], "t": [0.0, 0.0, 0.0]},
                           "exposure": exposure, "mask": f"masks/{stem}.png"})
        with open(os.path.join(folder, "scene.json"), "w") as f:
            json.dump({"format": "svbrdf-scene/1", "images_color_space": "linear", "cameras": [camera],
                       "lights": lights, "images": images,
                       "info": {"written_by": "scripts/bench_diligent.py --peers-only (stand-in for import-ps)",
                                "mask": f"mask.png eroded {erode_px} (held-out) / {erode_training_px} (training) times "
                                        "(4-neighbour), minus pixels with a channel at 255",
                                "exposure_rule": exposure_rule}}, f, indent=1)
    return exposure


# ----------------------------------------------------------------------------------------------
# CLI steps


def heldout_signature(scene_path):
    sc = load_scene(scene_path)
    return [(e["file"], e["light"], round(e["exposure"], 9), tuple(np.round(e["to_light"], 6)),
             tuple(np.round(e["irradiance"], 6))) for e in sc["entries"]]


def run_cli_object(obj, folder, cli, work, hold_out_every, log, res, pics):
    truth = os.path.join(folder, "normal_gt.exr")
    caps = {"project_with_normals": os.path.join(work, "capture_normals"),
            "project_estimated_normals": os.path.join(work, "capture_estimated")}
    extra = {"project_with_normals": ["--normals", truth], "project_estimated_normals": ["--truth-normals", truth]}
    for method, cap in caps.items():
        shutil.rmtree(cap, ignore_errors=True)
        run([cli, "import-ps", folder, "--out", cap, "--hold-out-every", str(hold_out_every)] + extra[method], log)
    if heldout_signature(os.path.join(caps["project_with_normals"], "heldout", "scene.json")) != \
            heldout_signature(os.path.join(caps["project_estimated_normals"], "heldout", "scene.json")):
        res["warnings"].append("the two imports' held-out scenes differ (files/lights/exposures)")
    for method, cap in caps.items():
        mat, rel = os.path.join(work, "material_" + method), os.path.join(work, "relit_" + method)
        for d in (mat, rel):
            shutil.rmtree(d, ignore_errors=True)
        heldout = os.path.join(cap, "heldout", "scene.json")
        try:
            wall, _, rss = run([cli, "reconstruct", os.path.join(cap, "scene.json"), "--out", mat], log, timed_rss=True)
            res["wall_time_s"][method], res["peak_memory_mb"][method] = round(wall, 2), rss
            run([cli, "relight", mat, heldout, "--out", rel], log)
            _, out, _ = run([cli, "evaluate", rel, heldout], log)
        except StepError as e:
            res["errors"][method] = str(e)
            print(f"  {obj} {method}: {e}", flush=True)
            continue
        ev = parse_evaluate(out)
        res["psnr_db"][method], res["psnr_min_db"][method] = ev["psnr_mean_db"], ev["psnr_min_db"]
        res["rel_rmse"][method] = ev["rel_rmse_mean"]
        res["per_image_psnr_db"][method] = [m["psnr_db"] for m in ev["per_image"]]
        try:
            res["python_psnr_db"][method] = round(evaluate_py(heldout, rel)["psnr_mean_db"], 3)
            if abs(res["python_psnr_db"][method] - ev["psnr_mean_db"]) > 0.02:
                res["warnings"].append(f"{method}: CLI evaluate {ev['psnr_mean_db']:.3f} dB vs Python "
                                       f"{res['python_psnr_db'][method]:.3f} dB")
        except StepError as e:
            res["warnings"].append(f"python re-score of {method}: {e}")
        mj = os.path.join(mat, "material.json")
        if os.path.exists(mj):
            res["basis_materials"][method] = [{"name": b.get("name"), "label": b.get("label", b.get("model"))}
                                              for b in json.load(open(mj)).get("basis", [])]
        sj = os.path.join(mat, "report", "summary.json")
        if os.path.exists(sj):
            summ = json.load(open(sj))
            summ.pop("basis", None)                            # already in basis_materials
            if isinstance(summ.get("normals"), dict):
                summ["normals"].pop("rounds", None)
            res["summary"][method] = summ
        nc = os.path.join(mat, "normals_camera.exr")
        if os.path.exists(nc):
            pics["normals_" + method] = read_normals(nc)
        pics["relit_" + method] = rel
        print(f"  {obj} {METHOD_LABELS[method]}: {ev['psnr_mean_db']:.2f} dB, reconstruct {wall:.1f} s, "
              f"{rss or float('nan'):.0f} MB", flush=True)
    return caps["project_estimated_normals"]


# ----------------------------------------------------------------------------------------------
# One object


def empty_result(obj):
    res = {k: {} for k in ("psnr_db", "psnr_min_db", "rel_rmse", "python_psnr_db", "per_image_psnr_db",
                           "wall_time_s", "peak_memory_mb", "basis_materials", "summary", "normals_mae_deg",
                           "errors", "peers")}
    res["normals_mae_deg"]["published"] = {k: v[obj] for k, v in PUBLISHED_NORMALS.items() if obj in v}
    res.update({"warnings": [], "exposures": [], "figure": None})
    return res


def bench_object(obj, args, cli):
    folder = os.path.join(args.data, obj)
    work = os.path.join(args.work, obj)
    os.makedirs(work, exist_ok=True)
    log = os.path.join(work, "log.txt")
    open(log, "w").close()
    dlg = load_diligent(folder)
    res = empty_result(obj)
    pics = {}
    if args.peers_only:
        cap = os.path.join(work, "capture_python")
        res["exposure"] = python_import(dlg, cap, args.hold_out_every, 2, 0, args.peers_exposure)
        res["capture"] = "Python stand-in for import-ps"
    else:
        cap = run_cli_object(obj, folder, cli, work, args.hold_out_every, log, res, pics)
        res["capture"] = "svbrdf import-ps --truth-normals (peers read its scene.json files)"
    train, heldout = os.path.join(cap, "scene.json"), os.path.join(cap, "heldout", "scene.json")
    ho = load_scene(heldout)
    res["heldout_images"] = len(ho["entries"])
    res["training_images"] = len(load_scene(train)["entries"])
    res["exposures"] = sorted({e["exposure"] for e in ho["entries"]})

    peers = {"lambert_peer": lambda d: lambert_peer(train, heldout, dlg["normals"], d),
             "interpolation_peer": lambda d: interpolation_peer(train, heldout, d)}
    for method, fn in peers.items():
        d = os.path.join(work, "relit_" + method)
        shutil.rmtree(d, ignore_errors=True)
        t0 = time.monotonic()
        info = fn(d)
        info["wall_s"] = round(time.monotonic() - t0, 2)
        res["peers"][method] = info
        ev = evaluate_py(heldout, d)
        res["python_psnr_db"][method] = round(ev["psnr_mean_db"], 3)
        if args.peers_only:
            res["psnr_db"][method], res["psnr_min_db"][method] = ev["psnr_mean_db"], ev["psnr_min_db"]
            res["rel_rmse"][method] = ev["rel_rmse_mean"]
            res["per_image_psnr_db"][method] = [m["psnr_db"] for m in ev["per_image"]]
        else:
            try:
                _, out, _ = run([cli, "evaluate", d, heldout], log)
                cv = parse_evaluate(out)
                res["psnr_db"][method], res["psnr_min_db"][method] = cv["psnr_mean_db"], cv["psnr_min_db"]
                res["rel_rmse"][method] = cv["rel_rmse_mean"]
                res["per_image_psnr_db"][method] = [m["psnr_db"] for m in cv["per_image"]]
                if abs(cv["psnr_mean_db"] - ev["psnr_mean_db"]) > 0.02:
                    res["warnings"].append(f"{method}: CLI evaluate {cv['psnr_mean_db']:.3f} dB vs Python "
                                           f"{ev['psnr_mean_db']:.3f} dB")
            except StepError as e:
                res["errors"][method] = str(e)
        pics["relit_" + method] = d
        print(f"  {obj} {METHOD_LABELS[method]}: {res['psnr_db'].get(method, float('nan')):.2f} dB "
              f"(Python {ev['psnr_mean_db']:.2f})", flush=True)

    # Normals: the project's estimate, and Python's Lambertian least squares as a sanity check.
    gt, mask = dlg["normals"], dlg["mask"]
    if "normals_project_estimated_normals" in pics:
        res["normals_mae_deg"]["project_estimated"] = angular_error(pics["normals_project_estimated_normals"], gt, mask)
        summ = res["summary"].get("project_estimated_normals", {})
        rep = summ.get("normals_mean_angular_error_deg")
        if rep is None and isinstance(summ.get("normals"), dict):
            rep = summ["normals"].get("mean_angular_error_deg")
        if rep is not None:
            res["normals_mae_deg"]["project_summary_reported"] = rep
    ls_train = lambertian_ls_normals(train)
    pics["normals_python_ls"] = ls_train
    res["normals_mae_deg"]["python_lambertian_ls_training_lights"] = angular_error(ls_train, gt, mask)
    res["normals_mae_deg"]["python_lambertian_ls_96_lights"] = angular_error(lambertian_ls_diligent(dlg), gt, mask)

    res["figure"] = object_figure(obj, res, heldout, pics, gt, mask, args.out + f"_{obj}.png")
    return res


# ----------------------------------------------------------------------------------------------
# Figures and tables


def display(img, gain):
    return np.clip(linear_to_srgb(np.clip(img * gain, 0, 1)), 0, 1)


def normals_rgb(n, mask):
    """RGB = n * 0.5 + 0.5 inside the mask where there is a normal; black elsewhere."""
    show = mask & (np.linalg.norm(n, axis=2) > 0.5)
    return np.where(show[..., None], np.clip(n * 0.5 + 0.5, 0, 1), 0.0)


def object_figure(obj, res, heldout, pics, gt, mask, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sc = load_scene(heldout)
    # The held-out light closest to 30 degrees from the viewing direction (shading and shadows show).
    ang = [abs(math.degrees(math.acos(min(1.0, max(-1.0, -e["to_light"][2])))) - 30) for e in sc["entries"]]
    i = int(np.argmin(ang))
    e = sc["entries"][i]
    photo, valid = load_entry(e, sc["space"])
    if "relit_project_estimated_normals" in pics:
        method, nkey, nlabel = "project_estimated_normals", "normals_project_estimated_normals", "project estimate"
    else:
        method, nkey, nlabel = "interpolation_peer", "normals_python_ls", "Python Lambertian LS (training lights)"
    relit = rgb(read_image(os.path.join(pics["relit_" + method], e["file"]), sc["space"])[0]).astype(np.float64)
    inside = valid
    gain = 1.0 / max(np.percentile(photo[inside] / e["exposure"], 99.5), 1e-6) / e["exposure"]
    err = np.abs(relit - photo).mean(axis=2) / e["exposure"]
    err[~inside] = np.nan
    per = res["per_image_psnr_db"].get(method, [])
    psnr = per[i] if i < len(per) else None
    est = pics.get(nkey)
    has_est = est is not None
    ae = angular_error(est, gt, mask)["mean_deg"] if has_est else None

    npan = 5 if has_est else 3
    panel_w = 2.5 * min(2.0, max(0.6, photo.shape[1] / photo.shape[0]))
    fig, ax = plt.subplots(1, npan, figsize=(npan * panel_w + 0.8, 3.3))
    ax[0].imshow(display(photo, gain))
    ax[0].set_title(f"photo (held-out light {e['light']})", fontsize=9)
    ax[1].imshow(display(relit, gain))
    ax[1].set_title(f"{METHOD_LABELS[method]}\n{psnr:.2f} dB" if psnr is not None else METHOD_LABELS[method], fontsize=9)
    vmax = max(np.nanpercentile(err, 99), 1e-6)
    cmap = matplotlib.colormaps["magma"].copy()
    cmap.set_bad("0.8")                                       # outside the photo's mask
    im = ax[2].imshow(err, cmap=cmap, vmin=0, vmax=vmax)
    ax[2].set_title("|relit - photo| / exposure\n(grey: outside the photo's mask)", fontsize=9)
    fig.colorbar(im, ax=ax[2], fraction=0.046, pad=0.02).ax.tick_params(labelsize=7)
    if has_est:
        ax[3].imshow(normals_rgb(est, mask))
        ax[3].set_title(f"normals: {nlabel}\nmean error {ae:.2f} deg", fontsize=9)
        ax[4].imshow(normals_rgb(gt, mask))
        ax[4].set_title("normals: ground truth", fontsize=9)
    for a in ax:
        a.set_xticks([])
        a.set_yticks([])
    fig.suptitle(f"DiLiGenT {obj}", fontsize=10)
    fig.tight_layout()
    for dpi in (80, 64, 50):
        fig.savefig(path, dpi=dpi)
        if os.path.getsize(path) < 290_000:
            break
    plt.close(fig)
    return os.path.basename(path)


def bar_chart(results, path, peers_only):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    objs = list(results["objects"])
    methods = [m for m in METHODS if any(m in results["objects"][o]["psnr_db"] for o in objs)]
    fig, ax = plt.subplots(figsize=(7, 4.0))
    wbar = 0.8 / max(len(methods), 1)
    for j, m in enumerate(methods):
        vals = [results["objects"][o]["psnr_db"].get(m, np.nan) for o in objs]
        xs = np.arange(len(objs)) + (j - (len(methods) - 1) / 2) * wbar
        bars = ax.bar(xs, vals, wbar, label=METHOD_LABELS[m])
        for x, v in zip(xs, vals):
            if np.isfinite(v):
                ax.text(x, v + 0.2, f"{v:.1f}", ha="center", fontsize=7)
    ax.set_xticks(np.arange(len(objs)))
    ax.set_xticklabels(objs)
    ax.set_ylabel("held-out mean PSNR (sRGB, dB)")
    fin = [v for o in objs for v in results["objects"][o]["psnr_db"].values() if np.isfinite(v)]
    if fin:
        ax.set_ylim(max(0, min(fin) - 5), max(fin) + 2)
    ax.set_title("DiLiGenT: 16 held-out lights (every 6th)" + (" - peers only" if peers_only else ""), fontsize=10)
    if methods:
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def fmt(v, f=".2f"):
    return "–" if v is None or (isinstance(v, float) and not np.isfinite(v)) else format(v, f)


def write_md(results, path):
    objs = list(results["objects"])
    R = results["objects"]
    p = results["protocol"]
    real = any(R[o]["normals_mae_deg"]["published"] for o in objs)
    title = "DiLiGenT (real photographs)" if real else f"Photometric-stereo objects from {p.get('data', '?')}"
    L = [f"# {title}: held-out relighting and normals", "",
         f"Generated {results['generated']} by `scripts/bench_diligent.py`"
         + (" **--peers-only** (the project's CLI was not run; captures from the script's Python stand-in for "
            "import-ps)" if p["peers_only"] else "") + ".", "",
         "Protocol: for each object the 96 lights are split into 80 training photos and 16 held-out photos "
         f"(lights {p['hold_out_every']}, {2 * p['hold_out_every']}, …, 96); every method predicts the held-out photos "
         "from the training capture and is scored by the same function (`svbrdf evaluate`, lib/evaluate/metrics.cc: "
         "mean over the held-out photos of the sRGB PSNR inside each photo's mask — saturated pixels excluded — after "
         "dividing by the exposure and clamping to [0, 1])"
         + (", re-implemented in Python here" if p["peers_only"] else "") + ". "
         "The Lambert peer fits a per-pixel albedo with the true normals; the interpolation peer blends the 3 "
         "training photos whose lights are nearest in angle with weights 1/(angular distance), each normalised by "
         "its irradiance and exposure. The photos are dark (median 3–16 of 255), so the PSNR depends on the "
         "exposure the capture states: " + ", ".join(f"{o} {', '.join(fmt(x, '.4g') for x in R[o]['exposures'])}"
                                                    for o in objs) + ".", "",
         "## Held-out PSNR (dB, mean over 16 photos; min in brackets)", "",
         "| method | " + " | ".join(objs) + " |", "|---|" + "---:|" * len(objs)]
    for m in METHODS:
        cells = []
        for o in objs:
            v = R[o]["psnr_db"].get(m)
            cells.append(f"{fmt(v)} ({fmt(R[o]['psnr_min_db'].get(m))})" if v is not None
                         else ("failed" if m in R[o]["errors"] or "object" in R[o]["errors"] else "not run"))
        L.append(f"| {METHOD_LABELS[m]} | " + " | ".join(cells) + " |")
    L += ["", "## Normals: mean angular error (deg) inside the mask", "",
          "| method | " + " | ".join(objs) + " |", "|---|" + "---:|" * len(objs)]

    def nrow(label, key):
        cells = []
        for o in objs:
            v = R[o]["normals_mae_deg"].get(key)
            cells.append("–" if v is None else f"{fmt(v['mean_deg'])}" + (
                f" (coverage {v['coverage']:.0%})" if v.get("coverage", 1) < 0.999 else ""))
        L.append(f"| {label} | " + " | ".join(cells) + " |")

    nrow("**project estimate** (80 training lights)", "project_estimated")
    if any("project_summary_reported" in R[o]["normals_mae_deg"] for o in objs):
        L.append("| project estimate, as its report/summary.json states | " + " | ".join(
            fmt(R[o]["normals_mae_deg"].get("project_summary_reported")) for o in objs) + " |")
    nrow("Lambertian LS, this script (80 training lights, the capture's masks)", "python_lambertian_ls_training_lights")
    nrow("Lambertian LS, this script (all 96 lights and pixels: check of the last row)", "python_lambertian_ls_96_lights")
    for name in PUBLISHED_NORMALS if real else []:
        L.append(f"| {name}{'' if '8-bit' in name else ' (published)'} | " + " | ".join(
            fmt(R[o]["normals_mae_deg"]["published"].get(name)) for o in objs) + " |")
    L += ["", ("Published rows: from the data README (Shi et al., DiLiGenT, CVPR 2016 / TPAMI 2019, 16-bit "
               "originals, all 96 lights); the last one is that README's own Lambertian LS on these 8-bit copies. "
               if real else "No published results exist for these objects. ") +
          "Mean over the whole mask; a method that leaves pixels without a normal is averaged over the pixels it "
          "covers (coverage in brackets).", ""]
    if not p["peers_only"]:
        mach = p.get("machine", {})
        L += ["## Cost of `svbrdf reconstruct` and the basis materials chosen", "",
              f"Wall time and peak resident memory from `/usr/bin/time -v`; {mach.get('cpus')} CPUs, load average "
              f"{fmt(mach.get('load_average_at_start'))} when the run started.", "",
              "| object | variant | wall time (s) | peak memory (MB) | basis materials |", "|---|---|---:|---:|---|"]
        for o in objs:
            for m in METHODS[:2]:
                b = R[o]["basis_materials"].get(m)
                L.append(f"| {o} | {METHOD_LABELS[m]} | {fmt(R[o]['wall_time_s'].get(m), '.1f')} | "
                         f"{fmt(R[o]['peak_memory_mb'].get(m), '.0f')} | "
                         f"{(str(len(b)) + ': ' + ', '.join(x['name'] or x['label'] for x in b)) if b else '–'} |")
        L.append("")
    warn = [f"{o}: {w}" for o in objs for w in R[o]["warnings"]] + \
           [f"{o}: {m}: {e}" for o in objs for m, e in R[o]["errors"].items()]
    if warn:
        L += ["## Warnings and errors", ""] + [f"- {w}" for w in warn] + [""]
    L += [f"![PSNR per object and method]({os.path.basename(results['chart'])})", ""]
    for o in objs:
        if R[o]["figure"]:
            L += [f"![{o}]({R[o]['figure']})", ""]
    with open(path, "w") as f:
        f.write("\n".join(L) + "\n")


# ----------------------------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default="/work/shared/data/diligent")
    ap.add_argument("--objects", default="ball,cat,pot1")
    ap.add_argument("--cli", default=os.path.join(ROOT, "build", "apps", "svbrdf"))
    ap.add_argument("--work", default="/tmp/diligent_bench")
    ap.add_argument("--out", default=os.path.join(ROOT, "bench_results", "diligent"),
                    help="output prefix: OUT.json, OUT.md, OUT.png, OUT_<object>.png")
    ap.add_argument("--hold-out-every", type=int, default=6)
    ap.add_argument("--peers-only", action="store_true",
                    help="no CLI: Python split from the DiLiGenT folders, Python scoring")
    ap.add_argument("--peers-exposure", default="1",
                    help="--peers-only: exposure of every photo, a number or pNN = the NNth percentile of the "
                         "training pixel values inside the mask (maps it to 1)")
    args = ap.parse_args()
    args.out = os.path.abspath(args.out)
    os.makedirs(os.path.dirname(args.out), exist_ok=True)
    cli = os.path.abspath(args.cli)
    if not args.peers_only:
        if not os.access(cli, os.X_OK):
            sys.exit(f"{cli}: no CLI binary (build it, or use --peers-only)")
        if subprocess.run([cli, "import-ps", "--help"], stdout=subprocess.DEVNULL,
                          stderr=subprocess.DEVNULL).returncode != 0:
            sys.exit(f"{cli} import-ps --help fails: this CLI has no import-ps yet (use --peers-only)")
    results = {"generated": datetime.datetime.now().isoformat(timespec="seconds"),
               "protocol": {"data": args.data, "hold_out_every": args.hold_out_every, "peers_only": args.peers_only,
                            "peers_exposure": args.peers_exposure if args.peers_only else "from import-ps",
                            "metric": "svbrdf evaluate: mean sRGB PSNR inside the per-photo masks"
                                      + (" (Python re-implementation)" if args.peers_only else ""),
                            "interpolation_peer": "3 nearest training lights by angle, weights 1/angular distance",
                            "lambert_peer": "per-pixel albedo by least squares with the true normals",
                            "machine": {"cpus": os.cpu_count(), "load_average_at_start": os.getloadavg()[0]}},
               "objects": {}}
    objects = [o for o in args.objects.split(",") if o]
    for obj in objects:
        for f in ("filenames.txt", "light_directions.txt", "light_intensities.txt", "mask.png", "normal_gt.exr"):
            if not os.path.isfile(os.path.join(args.data, obj, f)):
                sys.exit(f"{os.path.join(args.data, obj, f)}: missing (--data is DiLiGenT's folder of objects)")
    for obj in objects:
        print(f"{obj}:", flush=True)
        try:
            results["objects"][obj] = bench_object(obj, args, cli)
        except StepError as e:  # e.g. import-ps failed: nothing to compare for this object
            print(f"  {obj}: {e}", flush=True)
            results["objects"][obj] = empty_result(obj)
            results["objects"][obj]["errors"]["object"] = str(e)
    results["chart"] = os.path.basename(args.out + ".png")
    bar_chart(results, args.out + ".png", args.peers_only)
    with open(args.out + ".json", "w") as f:
        json.dump(results, f, indent=1)
    write_md(results, args.out + ".md")
    print(f"wrote {args.out}.json, .md, .png and _<object>.png")


if __name__ == "__main__":
    main()
