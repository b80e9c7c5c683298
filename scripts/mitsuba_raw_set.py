#!/usr/bin/env python3
"""Renders a raw photo set for `svbrdf calibrate` / `svbrdf capture` with an
independent renderer, Mitsuba 3 (issue 25: the front half on a rig it was not
built with): a printed calibration board, a scanned bunny standing on it, one
mirror ball, one small spherical lamp and dim ambient light, photographed
like a user would (board-only calibration photos, then a ring of object
photos), with the hidden truth kept aside.

World = board frame, exactly as lib/calib/board.{h,cc} defines it:
  ChArUco:     origin at the outer corner of the pattern (the corner of the
               first square), chessboard corner (i, j) at ((i+1) s, (j+1) s, 0)
               (OpenCV's CharucoBoard chessboardCorners);
  chessboard:  origin at the first inner corner (the one next to the
               top-left black square of the drawing), corner (i, j) at
               (i s, j s, 0), cols x rows inner corners;
  x along the drawing's columns (right), y along its rows (down), z = x cross
  y: into the table. The camera, the bunny, the ball and the lamp are on the
  z < 0 side.
The board is a textured quad (diffuse, paper albedo 0.85, ink 0.04) drawn by
OpenCV at high resolution with a white margin, on a grey table 1 mm below it.

Output (DIR):
  photos/calib_NNNN.exr   board-only photos (linear EXR, exposure 1)
  photos/NNNN_b0.exr      object photos
  mesh.obj                the bunny in its own frame (metres)
  capture.json            what a user knows (board, ball, rough placement)
  truth/truth.json        camera, every pose, true placement, lamp, albedo,
                          and the check of the board frame (truth corners
                          projected vs OpenCV's detection in the renders)
  truth/masks/NNNN.png    true visible silhouette of the bunny per photo
  truth/board.png         the printed texture

Needs the Mitsuba 3 wheel and OpenCV >= 4.7 (cv2.aruco.CharucoBoard with
setLegacyPattern) in one venv:
    /work/scratch/mi/bin/pip install mitsuba numpy opencv-python-headless
    /work/scratch/mi/bin/python scripts/mitsuba_raw_set.py --layout charuco_a --out raw_a
Then: svbrdf capture raw_a --out cap_a (scripts/bench_front_half.py compares
with the truth).
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_capture import quat, write_obj  # noqa: E402  (this project's own Mitsuba helpers)

LAYOUTS = {
    # ChArUco: cols x rows = squares (lib/calib/board.h); "new" = OpenCV >= 4.6 pattern.
    "charuco_a": dict(pattern="charuco", cols=11, rows=8, square=0.030, marker=0.022, dictionary="DICT_5X5_100",
                      layout="new"),
    # Legacy (OpenCV < 4.6) pattern: differs from the new one only for an even row count.
    "charuco_b": dict(pattern="charuco", cols=10, rows=8, square=0.030, marker=0.018, dictionary="DICT_4X4_50",
                      layout="legacy"),
    "charuco_c": dict(pattern="charuco", cols=12, rows=9, square=0.025, marker=0.020, dictionary="DICT_6X6_250",
                      layout="new"),
    # Chessboard: cols x rows = inner corners; the bunny and the ball stand on the
    # paper's free side, off the pattern (a chessboard must be seen whole).
    "chessboard": dict(pattern="chessboard", cols=9, rows=6, square=0.025, layout="new"),
}
PAPER, INK, TABLE = 0.85, 0.04, 0.22
BUNNY_RGB = [0.62, 0.42, 0.28]


# ---------------------------------------------------------------------------- board
def make_board(spec, mm_margin, extra_right_mm, px_per_mm):
    """Printed sheet as an 8-bit-like image (0 ink .. 1 paper) and the affine map
    board metres -> continuous texture pixels (pixel (0,0)'s top-left corner at
    0; a pixel centre at +0.5)."""
    import cv2
    s = spec["square"]
    pps = int(round(s * 1e3 * px_per_mm))
    if spec["pattern"] == "charuco":
        board = charuco(spec)
        pat = board.generateImage((spec["cols"] * pps, spec["rows"] * pps), marginSize=0, borderBits=1)
        origin_sq = (0, 0)  # board origin at the pattern's outer corner
    else:
        nx, ny = spec["cols"] + 1, spec["rows"] + 1
        pat = np.full((ny * pps, nx * pps), 255, np.uint8)
        for j in range(ny):
            for i in range(nx):
                if (i + j) % 2 == 0:  # top-left square black, as DrawBoard
                    pat[j * pps:(j + 1) * pps, i * pps:(i + 1) * pps] = 0
        origin_sq = (1, 1)  # first inner corner
    m = int(round(mm_margin * px_per_mm))
    extra = int(round(extra_right_mm * px_per_mm))
    tex = cv2.copyMakeBorder(pat, m, m, m, m + extra, cv2.BORDER_CONSTANT, value=255)
    unit = pps / s
    tex_from_board = np.array([[unit, 0, m + origin_sq[0] * pps], [0, unit, m + origin_sq[1] * pps]], float)
    return tex.astype(np.float32) / 255.0, tex_from_board, pps


def charuco(spec):
    import cv2
    a = cv2.aruco
    d = a.getPredefinedDictionary(getattr(a, spec["dictionary"]))
    b = a.CharucoBoard((spec["cols"], spec["rows"]), spec["square"], spec["marker"], d)
    b.setLegacyPattern(spec["layout"] == "legacy")
    return b


def object_points(spec):
    """lib/calib/board.cc BoardSpec::ObjectPoints()."""
    s = spec["square"]
    if spec["pattern"] == "charuco":
        return np.array([[(i + 1) * s, (j + 1) * s, 0.0] for j in range(spec["rows"] - 1)
                         for i in range(spec["cols"] - 1)])
    return np.array([[i * s, j * s, 0.0] for j in range(spec["rows"]) for i in range(spec["cols"])])


def to_grey8(img):
    """lib/calib/board.cc ToDisplayGrey for linear input."""
    g = img[:, :, :3].mean(2)
    k = np.quantile(g, 0.99)
    g = np.clip(g / k if k > 0 else g, 0, 1)
    g = np.where(g <= 0.0031308, 12.92 * g, 1.055 * np.power(g, 1 / 2.4) - 0.055)
    return np.round(g * 255).astype(np.uint8)


def detect(grey, spec):
    """OpenCV detection -> (ids, points in COLMAP pixels), or None."""
    import cv2
    if spec["pattern"] == "chessboard":
        ok, pts = cv2.findChessboardCorners(grey, (spec["cols"], spec["rows"]),
                                            cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if not ok:
            return None
        pts = cv2.cornerSubPix(grey, pts, (5, 5), (-1, -1), (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 1e-4))
        return np.arange(len(pts)), pts.reshape(-1, 2) + 0.5
    det = cv2.aruco.CharucoDetector(charuco(spec))
    corners, ids, _, _ = det.detectBoard(grey)
    if ids is None or len(ids) < 6:
        return None
    corners = cv2.cornerSubPix(grey, corners.astype(np.float32), (3, 3), (-1, -1),
                               (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 50, 1e-4))
    return ids.ravel(), corners.reshape(-1, 2) + 0.5


def project(K, R, t, X):
    xc = X @ R.T + t
    return np.stack([K[0, 0] * xc[:, 0] / xc[:, 2] + K[0, 2], K[1, 1] * xc[:, 1] / xc[:, 2] + K[1, 2]], 1), xc[:, 2]


def board_check(img, spec, K, R, t):
    """Truth corners projected vs detection: by id and by nearest projection
    (a chessboard's corner order is ambiguous up to a 180 degree turn)."""
    d = detect(to_grey8(img), spec)
    if d is None:
        return {"detected": 0}
    ids, pts = d
    proj, _ = project(K, R, t, object_points(spec))
    by_id = np.linalg.norm(proj[ids] - pts, axis=1)
    nearest = np.min(np.linalg.norm(pts[:, None, :] - proj[None, :, :], axis=2), axis=1)
    return {"detected": int(len(ids)), "rms_px_by_id": float(np.sqrt(np.mean(by_id ** 2))),
            "max_px_by_id": float(by_id.max()),
            "mean_dxdy_px_by_id": (pts - proj[ids]).mean(0).tolist(), "rms_px_nearest": float(np.sqrt(np.mean(nearest ** 2))),
            "max_px_nearest": float(nearest.max())}


# ---------------------------------------------------------------------------- geometry
def look_at(eye, target, roll_deg):
    """cam_from_world (x right, y down, z forward; image 'down' towards the
    table, +z), then turned by roll about the optical axis."""
    z = target - eye
    z /= np.linalg.norm(z)
    down = np.array([0.0, 0.0, 1.0])
    y = down - down.dot(z) * z
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    r = np.stack([x, y, z])
    c, s = math.cos(math.radians(roll_deg)), math.sin(math.radians(roll_deg))
    r = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ r
    return r, -r @ eye


def axis_angle(axis, deg):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    th = math.radians(deg)
    return np.eye(3) + math.sin(th) * k + (1 - math.cos(th)) * k @ k


def read_obj(path):
    v, f = [], []
    for line in open(path):
        p = line.split()
        if p and p[0] == "v":
            v.append([float(x) for x in p[1:4]])
        elif p and p[0] == "f":
            idx = [int(x.split("/")[0]) - 1 for x in p[1:]]
            f += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    return np.array(v), np.array(f)


def pose_json(r, t):
    return {"q": quat(r), "t": [float(x) for x in t]}


# ---------------------------------------------------------------------------- main
def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--layout", required=True, choices=sorted(LAYOUTS))
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--smoke", action="store_true", help="6 + 6 photos, 4 spp (for a ctest; ~1 min)")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--calibration", type=int, default=12, help="board-only photos")
    ap.add_argument("--photos", type=int, default=16, help="object photos")
    ap.add_argument("--spp", type=int, default=9, help="samples per pixel (stratified; board corners)")
    ap.add_argument("--ball-spp", type=int, default=256, help="samples per pixel in the mirror ball's window")
    ap.add_argument("--max-depth", type=int, default=3, help="Mitsuba path depth (3: one indirect bounce)")
    ap.add_argument("--noise", type=float, default=0.003,
                    help="sensor noise: sigma = noise * sqrt(value * white paper value)")
    ap.add_argument("--mesh", help="the scan (default: scripts/scan_mesh.py bunny00 --faces 4000)")
    ap.add_argument("--lamp-intensity", type=float, default=0.4, help="W/sr per channel")
    ap.add_argument("--lamp-radius", type=float, default=0.005)
    ap.add_argument("--ambient", type=float, default=0.02, help="ambient irradiance / the lamp's on the board")
    ap.add_argument("--balls", type=int, default=1, choices=[1, 2],
                    help="mirror balls (2: a second one at the opposite corner, a baseline for the lamp's distance)")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    if args.smoke:
        # 640 x 480 still: at 320 x 240 the markers are ~2 px per bit and OpenCV finds few.
        args.calibration, args.photos, args.spp, args.ball_spp = 6, 6, 4, 256

    import cv2
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    mi.logger().set_log_level(mi.LogLevel.Warn)
    try:
        import drjit as dr
        dr.set_thread_count(args.threads)
    except Exception:
        pass
    t0 = time.time()
    rng = np.random.default_rng(args.seed)
    spec = dict(LAYOUTS[args.layout])
    W, H = args.width, args.height
    chess = spec["pattern"] == "chessboard"

    tmp = args.out.rstrip("/") + ".partial"
    shutil.rmtree(tmp, ignore_errors=True)
    for d in ("photos", "truth/masks"):
        os.makedirs(os.path.join(tmp, d))

    # ---- the printed sheet
    px_per_mm = 4.0
    tex, tex_from_board, pps = make_board(spec, 15.0, 150.0 if chess else 0.0, px_per_mm)
    th, tw = tex.shape
    cv2.imwrite(os.path.join(tmp, "truth", "board.png"), np.round(tex * 255).astype(np.uint8))
    lin_inv = np.linalg.inv(tex_from_board[:, :2])

    def board_at(u, v):  # board point at a fraction of the sheet
        b = lin_inv @ (np.array([u * tw, v * th]) - tex_from_board[:, 2])
        return np.array([b[0], b[1], 0.0])

    # The drawing itself detected as a check of tex_from_board (as DrawBoard does).
    d = detect(np.round(tex * 255).astype(np.uint8), spec)
    pred = (object_points(spec)[:, :2] @ tex_from_board[:, :2].T + tex_from_board[:, 2])
    texture_check = float(np.abs(pred[d[0]] - d[1]).max()) if d is not None else None
    if texture_check is None or texture_check > 0.5:
        sys.exit("mitsuba_raw_set: the drawn board does not match its object points (%s texels)" % texture_check)

    # Sheet corners in the board frame; the pattern's extent.
    sheet = [board_at(0, 0), board_at(1, 0), board_at(1, 1), board_at(0, 1)]
    obj = object_points(spec)
    if chess:
        pat_lo = obj.min(0)[:2] - spec["square"]
        pat_hi = obj.max(0)[:2] + spec["square"]
    else:
        pat_lo = np.zeros(2)
        pat_hi = np.array([spec["cols"], spec["rows"]]) * spec["square"]
    pat_centre = np.array([*(0.5 * (pat_lo + pat_hi)), 0.0])

    # ---- the scene's objects
    mesh_path = args.mesh
    if not mesh_path:
        mesh_path = os.path.join(tmp, "truth", "scan.obj")
        subprocess.run(["/usr/bin/python3", os.path.join(os.path.dirname(os.path.abspath(__file__)), "scan_mesh.py"),
                        "bunny00", "--faces", "4000", "--out", mesh_path], check=True, stdout=subprocess.DEVNULL)
    v0, faces = read_obj(mesh_path)
    # The bunny in its own frame (metres): 12 cm tall, its own axes (y up, as scanned).
    v0 = v0 - 0.5 * (v0.min(0) + v0.max(0))
    v_mesh = v0 * (0.12 / (v0[:, 1].max() - v0[:, 1].min()))
    write_obj(os.path.join(tmp, "mesh.obj"), v_mesh, None, faces)
    # True placement: mesh +y -> world -z (up), a random turn about the vertical,
    # standing on the board (lowest point 0.2 mm above the paper).
    yaw = rng.uniform(0, 360)
    r_up = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # columns: mesh x->world x, mesh y->world -z
    assert np.allclose(r_up @ [0, 1, 0], [0, 0, -1]) and np.linalg.det(r_up) > 0
    R_true = axis_angle([0, 0, 1], yaw) @ r_up
    if chess:  # on the free paper right of the pattern
        base = np.array([pat_hi[0] + 0.085, pat_centre[1] + 0.01, 0.0])
    else:
        base = pat_centre + np.array([rng.uniform(-0.02, 0.02), rng.uniform(-0.02, 0.02), 0.0])
    vw = v_mesh @ R_true.T
    t_true = base - np.array([0.5 * (vw[:, 0].min() + vw[:, 0].max()), 0.5 * (vw[:, 1].min() + vw[:, 1].max()),
                              vw[:, 2].max() + 0.0002])
    v_world = v_mesh @ R_true.T + t_true
    bunny_centre = 0.5 * (v_world.min(0) + v_world.max(0))
    # Rough placement: 5 degrees about a random axis, 2 cm in a random direction.
    ax = rng.normal(size=3)
    dirn = rng.normal(size=3)
    dirn /= np.linalg.norm(dirn)
    R_rough = axis_angle(ax, 5.0) @ R_true
    t_rough = t_true + 0.02 * dirn

    ball_r = 0.02
    if chess:
        ball = np.array([pat_hi[0] + 0.085, pat_lo[1] - 0.0 + 0.025, -ball_r])
        ball[1] = min(ball[1], bunny_centre[1] - 0.09)
    else:
        ball = np.array([*(pat_lo + np.array([0.16, 0.2]) * (pat_hi - pat_lo)), -ball_r])
    balls = [ball]
    if args.balls == 2:
        balls.append(np.array([*(pat_lo + np.array([0.84, 0.8]) * (pat_hi - pat_lo)), -ball_r]) if not chess else
                     np.array([pat_hi[0] + 0.085, bunny_centre[1] + 0.085, -ball_r]))
    # Lamp: 45 cm above the board, offset to one side.
    lamp = np.array([pat_centre[0] + 0.12, pat_centre[1] - 0.16, -0.45])
    I = args.lamp_intensity
    L_lamp = I / (math.pi * args.lamp_radius ** 2)  # sphere of radiance L: I = L * pi r^2 in every direction
    E_board = I * abs(lamp[2]) / np.linalg.norm(lamp - pat_centre) ** 3
    L_amb = args.ambient * E_board / math.pi  # uniform sky over the upper hemisphere: E = pi L
    white_level = PAPER / math.pi * E_board

    albedo = (INK + (PAPER - INK) * tex).astype(np.float32)
    board_bmp = mi.Bitmap(np.repeat(albedo[:, :, None], 3, axis=2))

    def quad(name, corners, uvs, bsdf):
        props = mi.Properties()
        props["bsdf"] = mi.load_dict(bsdf)
        m = mi.Mesh(name, 4, 2, props=props, has_vertex_texcoords=True)
        p = mi.traverse(m)
        p["vertex_positions"] = np.asarray(corners, np.float32).ravel().tolist()
        p["vertex_texcoords"] = np.asarray(uvs, np.float32).ravel().tolist()
        p["faces"] = [0, 2, 1, 0, 3, 2]  # normal towards -z (the camera side)
        p.update()
        return m

    # Mitsuba's bitmap: uv (0, 0) is the top-left of the image, v down the rows.
    sheet_bsdf = {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {
        "type": "bitmap", "bitmap": board_bmp, "raw": True, "filter_type": "bilinear", "wrap_mode": "clamp"}}}
    sheet_mesh = quad("sheet", sheet, [[0, 0], [1, 0], [1, 1], [0, 1]], sheet_bsdf)
    big = 0.8
    c0 = pat_centre
    table_mesh = quad("table", [[c0[0] - big, c0[1] - big, 0.001], [c0[0] + big, c0[1] - big, 0.001],
                                [c0[0] + big, c0[1] + big, 0.001], [c0[0] - big, c0[1] + big, 0.001]],
                      [[0, 0], [1, 0], [1, 1], [0, 1]],
                      {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": TABLE}})

    def bunny_mesh(bsdf, emitter=None):
        props = mi.Properties()
        props["bsdf"] = mi.load_dict(bsdf)
        if emitter is not None:
            props["emitter"] = mi.load_dict(emitter)
        m = mi.Mesh("bunny", len(v_world), len(faces), props=props, has_vertex_normals=True)
        p = mi.traverse(m)
        p["vertex_positions"] = v_world.astype(np.float32).ravel().tolist()
        p["faces"] = faces.astype(np.uint32).ravel().tolist()
        p.update()
        m.recompute_vertex_normals()
        return m

    bunny_bsdf = {"type": "roughplastic", "distribution": "ggx", "alpha": 0.15, "int_ior": 1.5,
                  "diffuse_reflectance": {"type": "rgb", "value": BUNNY_RGB}, "nonlinear": False}
    ball_dicts = {"ball%d" % k: {"type": "sphere", "center": b.tolist(), "radius": ball_r,
                                 "bsdf": {"type": "conductor", "material": "Al"}} for k, b in enumerate(balls)}
    lamp_dict = {"type": "sphere", "center": lamp.tolist(), "radius": args.lamp_radius,
                 "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [L_lamp] * 3}}}
    # The ambient sky is reached by BSDF sampling only (emitter sampling would pick it
    # half of the time and leave the lamp's light, 98 % of the board's, noisy).
    env = {"type": "constant", "radiance": {"type": "rgb", "value": [L_amb] * 3}, "sampling_weight": 0.0}
    integrator = {"type": "path", "max_depth": args.max_depth}
    base_scene = {"type": "scene", "integrator": integrator, "sheet": sheet_mesh, "table": table_mesh,
                  "lamp": lamp_dict, "env": env}
    calib_scene = mi.load_dict(base_scene)
    full = dict(base_scene)
    full.update({"bunny": bunny_mesh(bunny_bsdf), **ball_dicts})
    object_scene = mi.load_dict(full)
    black = {"type": "diffuse", "reflectance": 0.0}
    cover_scene = mi.load_dict({
        "type": "scene", "integrator": {"type": "direct", "hide_emitters": False},
        "bunny": bunny_mesh(black, {"type": "area", "radiance": 1.0}),
        "sheet": quad("sheet", sheet, [[0, 0], [1, 0], [1, 1], [0, 1]], black),
        **{k: dict(b, bsdf=black) for k, b in ball_dicts.items()}})

    # ---- camera
    fx = 1.2 * W
    fy = fx
    cx, cy = W / 2 + 0.0065 * W, H / 2 - 0.0045 * H  # a slightly off-centre principal point
    K = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])
    fov = math.degrees(2 * math.atan(W / 2 / fx))

    def sensor(r, t, spp, seed, crop=None):
        eye = -r.T @ t
        world_from_cam = np.eye(4)
        world_from_cam[:3, :3] = r.T @ np.diag([-1.0, -1.0, 1.0])  # Mitsuba's camera: x left, y up
        world_from_cam[:3, 3] = eye
        film = {"type": "hdrfilm", "width": W, "height": H, "rfilter": {"type": "box"}, "pixel_format": "rgb"}
        if crop is not None:
            film.update({"crop_offset_x": crop[0], "crop_offset_y": crop[1], "crop_width": crop[2],
                         "crop_height": crop[3]})
        return mi.load_dict({"type": "perspective", "fov": fov, "fov_axis": "x",
                             "principal_point_offset_x": -(cx - W / 2) / W,
                             "principal_point_offset_y": -(cy - H / 2) / H,
                             "near_clip": 0.01, "far_clip": 10.0,
                             "to_world": mi.ScalarTransform4f(world_from_cam.tolist()), "film": film,
                             "sampler": {"type": "stratified", "sample_count": spp, "seed": seed}})

    # Intrinsics check: Mitsuba's rays through film positions vs the pinhole K.
    s0 = sensor(np.eye(3), np.zeros(3), 1, 0)
    k_err = 0.0
    for p in [(0.5, 0.5), (0.0, 0.0), (1.0, 1.0), (0.2, 0.9)]:
        ray = s0.sample_ray(0.0, 0.5, mi.Point2f(*p), mi.Point2f(0.5, 0.5))[0]
        dcam = np.array(ray.d)  # world == camera here (R = I): x right, y down
        px = np.array([fx * dcam[0] / dcam[2] + cx, fy * dcam[1] / dcam[2] + cy])
        k_err = max(k_err, float(np.abs(px - np.array(p) * [W, H]).max()))
    if k_err > 1e-3:
        sys.exit("mitsuba_raw_set: Mitsuba's camera does not match K (%.4f px)" % k_err)

    def render(scene, r, t, seed, with_ball):
        img = np.array(mi.render(scene, sensor=sensor(r, t, args.spp, seed)), dtype=np.float64)[:, :, :3]
        for ball in (balls if with_ball else []):  # the lamp's image in a ball is sub-pixel: many more samples there
            pc, zc = project(K, r, t, ball[None, :])
            if zc[0] > ball_r:
                rp = fx * ball_r / math.sqrt(max(zc[0] ** 2 - ball_r ** 2, 1e-9)) * 1.3 + 3
                x0, y0 = int(max(0, pc[0, 0] - rp)), int(max(0, pc[0, 1] - rp))
                x1, y1 = int(min(W, pc[0, 0] + rp + 1)), int(min(H, pc[0, 1] + rp + 1))
                if x1 > x0 and y1 > y0:
                    crop = mi.render(scene, sensor=sensor(r, t, args.ball_spp, seed + 7, (x0, y0, x1 - x0, y1 - y0)))
                    img[y0:y1, x0:x1] = np.array(crop, dtype=np.float64)[:, :, :3]
        if args.noise > 0:
            img = img + rng.normal(size=img.shape) * args.noise * np.sqrt(np.maximum(img, 0) * white_level)
        return np.maximum(img, 0).astype(np.float32)

    def write_exr(path, img):
        mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB).write(path)

    def in_view(r, t, pts, margin):
        p, z = project(K, r, t, pts)
        ok = (z > 0) & (p[:, 0] > margin) & (p[:, 0] < W - margin) & (p[:, 1] > margin) & (p[:, 1] < H - margin)
        return ok

    truth_cal, checks_cal, calib_files = [], [], []
    print("%s: %dx%d, %d calibration + %d object photos, %d spp" % (args.layout, W, H, args.calibration, args.photos,
                                                                    args.spp), flush=True)
    scale = W / 640.0
    for i in range(args.calibration):
        for attempt in range(500):
            az = 2 * math.pi * (i + rng.uniform(0, 0.6)) / args.calibration
            el = math.radians(rng.uniform(35, 72))
            target = np.array([*(pat_lo + rng.uniform(0.3, 0.7, 2) * (pat_hi - pat_lo)), 0.0])
            dist = rng.uniform(0.42, 0.75)
            eye = target + dist * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), -math.sin(el)])
            roll = 360.0 * (i + 0.5) / args.calibration + rng.uniform(-15, 15)
            r, t = look_at(eye, target, roll)
            vis = in_view(r, t, obj, 12 * scale)
            if vis.all() if chess else vis.mean() >= 0.75:
                break
        img = render(calib_scene, r, t, 100 + i, False)
        name = "photos/calib_%04d.exr" % i
        write_exr(os.path.join(tmp, name), img)
        calib_files.append(name)
        truth_cal.append(pose_json(r, t))
        checks_cal.append(dict(board_check(img, spec, K, r, t), photo=name))
        print("  %s  %s  (%.0f s)" % (name, checks_cal[-1], time.time() - t0), flush=True)

    truth_obj, checks_obj, photos, mask_ious = [], [], [], []
    target0 = bunny_centre if not chess else 0.55 * bunny_centre + 0.45 * pat_centre
    ring_centre = np.array([bunny_centre[0], bunny_centre[1], 0.0]) if not chess else np.array([*target0[:2], 0.0])
    for i in range(args.photos):
        az = 2 * math.pi * (i + rng.uniform(-0.2, 0.2)) / args.photos
        el = math.radians([32, 42, 52, 62][i % 4] + rng.uniform(-3, 3))
        dist = rng.uniform(0.45, 0.55) + (0.12 if chess else 0.0)
        target = target0 + rng.normal(size=3) * 0.01
        eye = ring_centre + dist * np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), -math.sin(el)])
        r, t = look_at(eye, target, rng.uniform(-8, 8))
        img = render(object_scene, r, t, 1000 + i, True)
        name = "photos/%04d_b0.exr" % i
        write_exr(os.path.join(tmp, name), img)
        cov = np.array(mi.render(cover_scene, sensor=sensor(r, t, 9, 5000 + i)))[:, :, 0]
        mask = np.where(cov >= 0.5, 255, 0).astype(np.uint8)
        cv2.imwrite(os.path.join(tmp, "truth", "masks", "%04d.png" % i), mask)
        photos.append({"files": [name], "exposures": [1.0], "light": 1})
        truth_obj.append(pose_json(r, t))
        checks_obj.append(dict(board_check(img, spec, K, r, t), photo=name))
        print("  %s  %s  (%.0f s)" % (name, checks_obj[-1], time.time() - t0), flush=True)

    board_json = {k: spec[k] for k in ("pattern", "cols", "rows", "square")}
    if not chess:
        board_json.update(marker=spec["marker"], dictionary=spec["dictionary"])
    if spec["layout"] != "new":
        board_json["layout"] = spec["layout"]
    desc = {"format": "svbrdf-capture-description/1", "board": board_json,
            "camera": {"calibrate": True, "model": "PINHOLE"}, "poses": "board",
            "calibration_photos": calib_files, "images_color_space": "linear",
            "mesh": {"file": "mesh.obj", "world_from_mesh": pose_json(R_rough, t_rough)},
            "masks": "grabcut",
            "mirror_spheres": {"radius": ball_r, "centres": [b.tolist() for b in balls]},
            "lights": [{"id": 1, "type": "point"}], "photos": photos}
    with open(os.path.join(tmp, "capture.json"), "w") as f:
        json.dump(desc, f, indent=1)

    def stats(checks, key):
        vals = [c[key] for c in checks if c.get("detected")]
        return max(vals) if vals else None

    truth = {
        "renderer": "mitsuba %s scalar_rgb, path max_depth %d, %d spp (%d in the ball's window), box filter"
                    % (mi.__version__, args.max_depth, args.spp, args.ball_spp),
        "layout": args.layout, "board": dict(spec, paper_albedo=PAPER, ink_albedo=INK,
                                             texture_from_board=tex_from_board.tolist(),
                                             texture_pixels_per_square=pps, texture_size=[tw, th],
                                             sheet_corners=[c.tolist() for c in sheet]),
        "board_paper_albedo": PAPER, "board_ink_albedo": INK, "table_albedo": TABLE,
        "camera": {"model": "PINHOLE", "width": W, "height": H, "params": [fx, fy, cx, cy]},
        "world_from_object": pose_json(R_true, t_true),
        "world_from_mesh": pose_json(R_true, t_true),
        "world_from_mesh_rough": pose_json(R_rough, t_rough),
        "rough_error": {"deg": 5.0, "mm": 20.0, "axis": (ax / np.linalg.norm(ax)).tolist(), "direction": dirn.tolist()},
        "lamps": [lamp.tolist()],
        "lamp": {"position": lamp.tolist(), "radius": args.lamp_radius, "intensity": [I] * 3,
                 "radiance": [L_lamp] * 3, "intensity_is": "radiance * pi r^2 (W/sr per RGB channel)"},
        "ambient": {"radiance": [L_amb] * 3, "irradiance_share_on_board": args.ambient},
        "board_irradiance_at_pattern_centre": E_board, "white_paper_radiance_at_pattern_centre": white_level,
        "mirror_spheres": {"radius": ball_r, "centres": [b.tolist() for b in balls], "material": "Mitsuba conductor Al"},
        "object_material": bunny_bsdf,
        "cam_from_world": truth_obj, "calibration_cam_from_world": truth_cal,
        "truth_masks": "truth/masks/NNNN.png (visible bunny, pixel coverage >= 0.5)",
        "conventions": {
            "world": "board frame of lib/calib/board.cc (ObjectPoints), board in z = 0, camera/object at z < 0",
            "cam_from_world": "COLMAP: x right, y down, z forward; q = w x y z",
            "pixels": "COLMAP: centre of the top-left pixel at (0.5, 0.5)"},
        "check": {"mitsuba_rays_vs_K_px": k_err, "drawn_texture_vs_object_points_texels": texture_check,
                  "calibration_photos": checks_cal, "object_photos": checks_obj,
                  "worst_px_by_id_calibration": stats(checks_cal, "max_px_by_id"),
                  "worst_px_nearest_all": stats(checks_cal + checks_obj, "max_px_nearest")},
        "options": vars(args), "seconds": None}
    truth["seconds"] = round(time.time() - t0, 1)
    with open(os.path.join(tmp, "truth", "truth.json"), "w") as f:
        json.dump(truth, f, indent=1)
    if os.path.exists(args.out):
        shutil.rmtree(args.out)
    os.rename(tmp, args.out)
    print("raw set %s (%s) in %.0f s; board check: worst %.3f px (calibration, by id), %s px (nearest, all)"
          % (args.out, args.layout, time.time() - t0, truth["check"]["worst_px_by_id_calibration"] or -1,
             truth["check"]["worst_px_nearest_all"]), flush=True)


if __name__ == "__main__":
    sys.exit(main())
