#!/usr/bin/python3
"""Cuts the small real test capture tests/data/diligent_cat_crop/ out of DiLiGenT's `cat`.

The output has the layout of a DiLiGenT object folder (what `svbrdf import-ps` reads):
001.png ... 096.png (the 8-bit linear photos, cropped, bytes unchanged), filenames.txt,
light_directions.txt, light_intensities.txt (copied: the lights do not depend on the crop),
mask.png (cropped) and normal_gt.exr (cropped, float). The rectangle is 40 x 40 px around the
ear at the top right of the photo: it holds the white head, the pink inside of the ear (a second
albedo), curved normals and the mask boundary on two sides. Re-running this script reproduces the folder byte for byte for the PNGs and text files.

Usage: /usr/bin/python3 scripts/make_diligent_crop.py [--data /work/shared/data/diligent/cat]
                                                     [--out tests/data/diligent_cat_crop]
"""
import argparse
import os
import shutil
import sys

import cv2
import numpy as np
import OpenImageIO as oiio

# x0, y0 (top-left pixel, 0-based, row 0 at the top), width, height in the cropped DiLiGenT cat
# photos (296 x 320 px, `pmsData_crop`).
CROP = (238, 46, 40, 40)

README = """# A 40 x 40 px crop of DiLiGenT `cat` (real photographs, 96 directional lights)

Made by `scripts/make_diligent_crop.py` from `/work/shared/data/diligent/cat` (DiLiGenT's cropped
version, `pmsData_crop`, 296 x 320 px). Crop rectangle: **x = {x0} .. {x1}, y = {y0} .. {y1}
(inclusive; 0-based pixels, row 0 at the top), i.e. x0 = {x0}, y0 = {y0}, width = {w}, height =
{h}** — the cat's ear at the top right of the photo: white head, the pink inside of the ear, curved
normals, and the mask boundary along the top and the right. {inside} of the {n} pixels are inside the
mask.

Same layout as a DiLiGenT object folder, so `svbrdf import-ps` reads it:

| file | content |
|---|---|
| `001.png … 096.png` | the photos cropped (RGB, 8 bit, **linear**, bytes unchanged) |
| `filenames.txt` | the image of each light, in order (copied) |
| `light_directions.txt` | 96 × 3 unit vectors towards each light, camera frame x right, y up, z towards the camera (copied) |
| `light_intensities.txt` | 96 × 3 RGB light intensities; divide the image channels by them (copied) |
| `mask.png` | the object mask, cropped |
| `normal_gt.exr` | ground-truth unit normals (float RGB = xyz, same frame, zero outside the mask), cropped |

Source: B. Shi, Z. Mo, Z. Wu, D. Duan, S.-K. Yeung, P. Tan, "A Benchmark Dataset and Evaluation
for Non-Lambertian and Uncalibrated Photometric Stereo", CVPR 2016 / TPAMI 2019 (DiLiGenT).
Research use; cite the paper.
"""


def read_float_image(path):
    inp = oiio.ImageInput.open(path)
    if not inp:
        sys.exit(f"{path}: cannot read: {oiio.geterror()}")
    spec = inp.spec()
    px = inp.read_image(0, 0, 0, spec.nchannels, oiio.FLOAT)
    inp.close()
    if px is None:
        sys.exit(f"{path}: cannot read pixels")
    return np.asarray(px, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels), spec


def write_float_exr(path, arr, channel_names):
    h, w, c = arr.shape
    spec = oiio.ImageSpec(w, h, c, oiio.FLOAT)
    spec.channelnames = tuple(channel_names)
    spec.attribute("compression", "zip")
    out = oiio.ImageOutput.create(path)
    if not out or not out.open(path, spec):
        sys.exit(f"{path}: cannot write: {oiio.geterror()}")
    ok = out.write_image(np.ascontiguousarray(arr, dtype=np.float32))
    out.close()
    if not ok:
        sys.exit(f"{path}: cannot write pixels")


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default="/work/shared/data/diligent/cat", help="DiLiGenT object folder")
    ap.add_argument("--out", default=os.path.normpath(os.path.join(here, "..", "tests", "data", "diligent_cat_crop")))
    args = ap.parse_args()

    x0, y0, w, h = CROP
    names = [l.strip() for l in open(os.path.join(args.data, "filenames.txt")) if l.strip()]
    if len(names) != 96:
        sys.exit(f"{args.data}/filenames.txt: expected 96 names, got {len(names)}")
    os.makedirs(args.out, exist_ok=True)
    png_params = [cv2.IMWRITE_PNG_COMPRESSION, 9]

    def crop_png(src, dst):
        img = cv2.imread(src, cv2.IMREAD_UNCHANGED)  # bytes as stored (BGR order in and out)
        if img is None:
            sys.exit(f"{src}: cannot read")
        if img.shape[0] < y0 + h or img.shape[1] < x0 + w:
            sys.exit(f"{src}: {img.shape[1]}x{img.shape[0]} is smaller than the crop {CROP}")
        if not cv2.imwrite(dst, np.ascontiguousarray(img[y0:y0 + h, x0:x0 + w]), png_params):
            sys.exit(f"{dst}: cannot write")
        return img

    for name in names:
        crop_png(os.path.join(args.data, name), os.path.join(args.out, name))
    mask = crop_png(os.path.join(args.data, "mask.png"), os.path.join(args.out, "mask.png"))
    for txt in ("filenames.txt", "light_directions.txt", "light_intensities.txt"):
        shutil.copyfile(os.path.join(args.data, txt), os.path.join(args.out, txt))

    normals, spec = read_float_image(os.path.join(args.data, "normal_gt.exr"))
    write_float_exr(os.path.join(args.out, "normal_gt.exr"), normals[y0:y0 + h, x0:x0 + w],
                    spec.channelnames)

    m = mask[y0:y0 + h, x0:x0 + w]
    inside = int(np.count_nonzero(m.reshape(h, w, -1).max(axis=2)))
    with open(os.path.join(args.out, "README.md"), "w") as f:
        f.write(README.format(x0=x0, y0=y0, x1=x0 + w - 1, y1=y0 + h - 1, w=w, h=h, inside=inside, n=w * h))
    total = sum(os.path.getsize(os.path.join(args.out, f)) for f in os.listdir(args.out))
    print(f"wrote {args.out}: crop x0={x0} y0={y0} {w}x{h}, {inside}/{w * h} px in the mask, "
          f"{len(os.listdir(args.out))} files, {total / 1024:.0f} KB")


if __name__ == "__main__":
    main()
