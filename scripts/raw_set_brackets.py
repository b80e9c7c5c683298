#!/usr/bin/python3
"""A raw set's linear photos as exposure brackets, as a camera writes them.

Turns every photo of a raw set (capture.json + linear EXR photos, e.g. from
scripts/mitsuba_raw_set.py) into N brackets of 16-bit linear PNG, STOPS
stops apart: bracket k = clip(radiance x scale x 2^(-k STOPS), 0, 1),
quantised to 16 bits, with `scale` putting the photo's 99.5th percentile at
0.9 of full scale in bracket 0, so that highlights clip there and only the
darker brackets hold them (as in a real bracketed shot). The calibration
photos become one 16-bit bracket each; truth/ and the mesh are linked.

Usage: /usr/bin/python3 scripts/raw_set_brackets.py SRC DST [--brackets 3] [--stops 3]
"""
import argparse
import json
import os
import shutil

import numpy as np
import OpenImageIO as oiio


def read(path):
    return oiio.ImageBuf(path).get_pixels(oiio.FLOAT)


def write_png16(path, img):
    spec = oiio.ImageSpec(img.shape[1], img.shape[0], img.shape[2], oiio.UINT16)
    out = oiio.ImageOutput.create(path)
    if out is None or not out.open(path, spec):
        raise SystemExit(f"raw_set_brackets: cannot write {path}")
    out.write_image(np.round(np.clip(img, 0, 1) * 65535).astype(np.uint16))
    out.close()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("src")
    ap.add_argument("dst")
    ap.add_argument("--brackets", type=int, default=3)
    ap.add_argument("--stops", type=float, default=3.0)
    a = ap.parse_args()
    desc = json.load(open(os.path.join(a.src, "capture.json")))
    os.makedirs(os.path.join(a.dst, "photos"), exist_ok=True)
    for entry in os.listdir(a.src):
        if entry not in ("photos", "capture.json"):
            target = os.path.join(a.dst, entry)
            if not os.path.exists(target):
                os.symlink(os.path.abspath(os.path.join(a.src, entry)), target)
    calib = []
    for f in desc.get("calibration_photos", []):
        img = read(os.path.join(a.src, f))
        name = "photos/" + os.path.splitext(os.path.basename(f))[0] + ".png"
        write_png16(os.path.join(a.dst, name), img * 0.9 / max(1e-12, np.percentile(img, 99.5)))
        calib.append(name)
    desc["calibration_photos"] = calib
    for p in desc["photos"]:
        img = read(os.path.join(a.src, p["files"][0])) / p["exposures"][0]
        scale = 0.9 / max(1e-12, np.percentile(img, 99.5))
        stem = os.path.splitext(os.path.basename(p["files"][0]))[0].replace("_b0", "")
        files, exposures = [], []
        for k in range(a.brackets):
            e = scale * 2.0 ** (-k * a.stops)
            name = f"photos/{stem}_b{k}.png"
            write_png16(os.path.join(a.dst, name), img * e)
            files.append(name)
            exposures.append(e)
        p["files"], p["exposures"] = files, exposures
    with open(os.path.join(a.dst, "capture.json"), "w") as f:
        json.dump(desc, f, indent=1)
    print(f"raw_set_brackets: {a.dst}: {len(desc['photos'])} photos x {a.brackets} brackets, {a.stops} stops apart")


if __name__ == "__main__":
    main()
