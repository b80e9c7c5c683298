#!/usr/bin/env python3
"""Renders a `svbrdf export --format gltf` model with Blender (headless Cycles,
the Khronos importer) from every image entry of a scene.json (its pinhole
camera, pose and point or directional light) and scores the renders against
that scene's photos, as `svbrdf evaluate` does: sRGB PSNR inside the photo's
mask after dividing by the exposure.

    python3 scripts/check_blender_gltf.py MODEL.gltf SCENE.json --work out/blender_check [--spp 64]

Conventions: glTF is y-up and the importer turns it z-up, (x, y, z) -> (x, -z, y);
our world coordinates go into the glTF unchanged, so cameras and lights get
the same turn. Cameras look along +z with y down (cam_from_world), Blender's
along -z with y up. A Cycles point light of power P emits P / (4 pi) W/sr
(measured: a white Lambertian plane under it), so P = 4 pi I. Direct light
only (max_bounces 0, as `relight`), box pixel filter (pixels integrate their
area), no denoising, black world. Needs Debian's `blender` (3.4).
Writes WORK/view_NNNN.exr and WORK/blender_agreement.json.
"""
import json
import math
import os
import subprocess
import sys

TURN = ((1, 0, 0), (0, 0, -1), (0, 1, 0))  # glTF y-up -> Blender z-up


def turn(p):
    return [sum(TURN[i][j] * p[j] for j in range(3)) for i in range(3)]


def quat_to_matrix(w, x, y, z):
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def render_in_blender(model, scene_path, work, spp):
    import bpy
    from mathutils import Matrix, Vector
    scene = json.load(open(scene_path))
    cams = {c["id"]: c for c in scene["cameras"]}
    lights = {l["id"]: l for l in scene["lights"]}
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.samples = spp
    sc.cycles.use_denoising = False
    sc.cycles.max_bounces = 0
    sc.cycles.pixel_filter_type = "BOX"
    sc.cycles.filter_width = 1.0
    sc.cycles.seed = 1
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.render.resolution_percentage = 100
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs[1].default_value = 0.0
    sc.world = world
    # Debian 12's Blender 3.4 importer still uses np.bool, which its numpy
    # 1.24 removed: restore the alias for the importer.
    import numpy
    if not hasattr(numpy, "bool") or numpy.bool is not bool:
        numpy.bool = bool
    bpy.ops.import_scene.gltf(filepath=model)
    cam_data = bpy.data.cameras.new("cam")
    cam = bpy.data.objects.new("cam", cam_data)
    sc.collection.objects.link(cam)
    sc.camera = cam
    out = []
    for i, e in enumerate(scene["images"]):
        c = cams[e["camera"]]
        if c["model"] not in ("PINHOLE", "SIMPLE_PINHOLE"):
            raise SystemExit(f"{scene_path}: images[{i}]: camera model {c['model']}: only pinhole cameras are rendered")
        p = c["params"]
        fx, fy, cx, cy = (p[0], p[0], p[1], p[2]) if c["model"] == "SIMPLE_PINHOLE" else p[:4]
        W, H = c["width"], c["height"]
        sc.render.resolution_x, sc.render.resolution_y = W, H
        cam_data.sensor_fit = "HORIZONTAL"
        cam_data.sensor_width = 36.0
        cam_data.lens = fx * 36.0 / W
        cam_data.shift_x = -(cx - W / 2) / W
        cam_data.shift_y = (cy - H / 2) / W
        sc.render.pixel_aspect_x, sc.render.pixel_aspect_y = 1.0, fx / fy
        R = quat_to_matrix(*e["cam_from_world"]["q"])
        t = e["cam_from_world"]["t"]
        # world_from_cam = [R^T | -R^T t]; Blender camera axes = ours with y, z flipped.
        Rt = [[R[j][i] for j in range(3)] for i in range(3)]
        centre = [-sum(Rt[i][j] * t[j] for j in range(3)) for i in range(3)]
        axes = [turn([Rt[r][k] * (1 if k == 0 else -1) for r in range(3)]) for k in range(3)]  # columns
        m = Matrix([[axes[0][r], axes[1][r], axes[2][r], turn(centre)[r]] for r in range(3)] + [[0, 0, 0, 1]])
        cam.matrix_world = m
        for o in [o for o in sc.objects if o.type == "LIGHT"]:
            bpy.data.objects.remove(o, do_unlink=True)
        L = lights[e["light"]]
        I = L["intensity"] if isinstance(L["intensity"], list) else [L["intensity"]] * 3
        peak = max(I)
        if L["type"] == "point":
            ld = bpy.data.lights.new("lamp", "POINT")
            ld.energy = 4 * math.pi * peak
            ld.shadow_soft_size = 0.0
        elif L["type"] == "directional":
            ld = bpy.data.lights.new("lamp", "SUN")
            ld.energy = peak  # W/m^2 of irradiance
            ld.angle = 0.0
        else:
            raise SystemExit(f"{scene_path}: light {L['id']}: type {L['type']} is not rendered here")
        ld.color = [v / peak for v in I] if peak > 0 else [0, 0, 0]
        lo = bpy.data.objects.new("lamp", ld)
        sc.collection.objects.link(lo)
        if L["type"] == "point":
            lo.location = turn(L["position"])
        else:
            # A sun shines along its local -z: point +z towards the light.
            lo.rotation_euler = Vector(turn(L["direction"])).to_track_quat("Z", "Y").to_euler()
        sc.render.filepath = os.path.join(work, f"view_{i:04d}.exr")
        bpy.ops.render.render(write_still=True)
        out.append(sc.render.filepath)
    json.dump(out, open(os.path.join(work, "renders.json"), "w"))


def srgb(x):
    import numpy as np
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def compare(scene_path, work):
    os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
    import cv2
    import numpy as np
    scene = json.load(open(scene_path))
    base = os.path.dirname(os.path.abspath(scene_path))
    rows = []
    for i, e in enumerate(scene["images"]):
        photo = cv2.imread(os.path.join(base, e["file"]), cv2.IMREAD_UNCHANGED)[..., :3][..., ::-1].astype(np.float64)
        render = cv2.imread(os.path.join(work, f"view_{i:04d}.exr"), cv2.IMREAD_UNCHANGED)[..., :3][..., ::-1].astype(np.float64)
        mask = cv2.imread(os.path.join(base, e["mask"]), cv2.IMREAD_UNCHANGED) > 0 if e.get("mask") else np.ones(photo.shape[:2], bool)
        if mask.ndim == 3:
            mask = mask[..., 0]
        ex = e.get("exposure", 1.0)
        a, b = render[mask] / ex, photo[mask] / ex
        mse = float(np.mean((srgb(a) - srgb(b)) ** 2))
        rows.append({"view": e["file"], "psnr_srgb": 10 * math.log10(1 / mse) if mse > 0 else float("inf"),
                     "rel_rmse_linear": float(np.sqrt(np.sum((a - b) ** 2) / max(np.sum(b ** 2), 1e-30)))})
        print(f"{e['file']}: Blender vs photo {rows[-1]['psnr_srgb']:.2f} dB, rel RMSE {rows[-1]['rel_rmse_linear']:.4f}")
    summary = {"scene": scene_path, "views": rows, "mean_psnr_srgb": float(np.mean([r["psnr_srgb"] for r in rows])),
               "min_psnr_srgb": float(np.min([r["psnr_srgb"] for r in rows]))}
    json.dump(summary, open(os.path.join(work, "blender_agreement.json"), "w"), indent=2)
    print(f"mean over {len(rows)} views: {summary['mean_psnr_srgb']:.2f} dB (min {summary['min_psnr_srgb']:.2f})")
    return summary


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    import argparse
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model")
    ap.add_argument("scene")
    ap.add_argument("--work", default="out/blender_check")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--in-blender", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    work = os.path.abspath(a.work)
    os.makedirs(work, exist_ok=True)
    if a.in_blender:
        render_in_blender(os.path.abspath(a.model), os.path.abspath(a.scene), work, a.spp)
        return 0
    subprocess.run(["blender", "-b", "--factory-startup", "--python-exit-code", "1", "-P", os.path.abspath(__file__), "--",
                    a.model, a.scene, "--work", work, "--spp", str(a.spp), "--in-blender"], check=True,
                   stdout=open(os.path.join(work, "blender.log"), "w"), stderr=subprocess.STDOUT)
    compare(a.scene, work)
    return 0


if __name__ == "__main__":
    sys.exit(main())
