#!/usr/bin/env python3
"""Mixing weights of a reconstruction against a synthetic capture's truth, per
true material: how far the weights of the texels that are purely one material
(true weight > 0.999) lie from the truth (1), overall (std) and from texel to
texel (high-frequency part: the texel minus the mean of its 8 neighbours), and
how much weight the other materials take there. Used for bench_results/mixed.md
("Mixing weights against the truth").

The truth (CAP/gt, usually 256x256) is resampled bilinearly at the
reconstruction's texel centres, as scripts/truth_mix.py does. Basis materials
are matched to the true ones by the majority of each true material's texels.

Usage (/usr/bin/python3: numpy and OpenImageIO):
  weight_error.py CAP REC [--perm 2,1,0]
    --perm  reconstruction's material index for each true material, in the
            truth's order (default: matched by overlap)
"""
import argparse, json
import numpy as np
import OpenImageIO as oiio


def load(path):
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise SystemExit('weight_error: cannot read %s' % path)
    a = np.array(inp.read_image(format='float'), dtype=np.float64)
    inp.close()
    return a if a.ndim == 3 else a[..., None]


def resize(img, R):
    """Bilinear resample to R x R at texel centres, clamped at the border (as truth_mix.py)."""
    H, W = img.shape[:2]
    if H == R and W == R:
        return img
    ys = (np.arange(R) + 0.5) * H / R - 0.5
    xs = (np.arange(R) + 0.5) * W / R - 0.5
    y0 = np.clip(np.floor(ys).astype(int), 0, H - 1)
    x0 = np.clip(np.floor(xs).astype(int), 0, W - 1)
    y1, x1 = np.clip(y0 + 1, 0, H - 1), np.clip(x0 + 1, 0, W - 1)
    fy = np.clip(ys - y0, 0, 1)[:, None, None]
    fx = np.clip(xs - x0, 0, 1)[None, :, None]
    top = img[y0][:, x0] * (1 - fx) + img[y0][:, x1] * fx
    bottom = img[y1][:, x0] * (1 - fx) + img[y1][:, x1] * fx
    return top * (1 - fy) + bottom * fy


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('cap')
    ap.add_argument('rec')
    ap.add_argument('--perm', default='')
    a = ap.parse_args()
    mg = json.load(open(a.cap + '/gt/material.json'))
    mr = json.load(open(a.rec + '/material.json'))
    R = mr['resolution'][0]
    truth = [resize(load(a.cap + '/gt/' + f), R)[..., 0] for f in mg['weights']]
    ours = [load(a.rec + '/' + f) for f in mr['weights']]
    covered = sum(truth) > 0.5
    true_label = np.argmax(np.stack(truth), 0)
    our_label = np.argmax(np.stack([w.mean(2) for w in ours]), 0)
    if a.perm:
        perm = [int(i) for i in a.perm.split(',')]
    else:
        perm = [int(np.bincount(our_label[covered & (true_label == k)], minlength=len(ours)).argmax())
                for k in range(len(truth))]
    print('resolution %d, reconstruction material for each true one: %s' % (R, perm))
    print('| true material | ours | pure texels | weight mean (r,g,b) | std / mean | texel-to-texel / mean | other weights (RMS) |')
    print('|---|---|---:|---|---:|---:|---:|')
    for k, t in enumerate(truth):
        w = ours[perm[k]]
        pure = covered & (t > 0.999)
        if not pure.any():
            continue
        mean = w[pure].mean(0)
        std = w[pure].std(0)
        pad = np.pad(w, ((1, 1), (1, 1), (0, 0)), mode='edge')
        around = sum(pad[1 + dy:1 + dy + R, 1 + dx:1 + dx + R]
                     for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx) / 8
        hf = np.sqrt(((w - around)[pure] ** 2).mean(0))
        others = sum(ours[perm[j]] for j in range(len(truth)) if j != k)[pure]
        fmt = lambda v: ', '.join('%.4f' % x for x in v)
        pct = lambda v: ', '.join('%.2f %%' % (100 * x) for x in v)
        print('| %d %s | m%d %s | %d | %s | %s | %s | %.4f |' % (
            k, mg['basis'][k].get('label', ''), perm[k], mr['basis'][perm[k]].get('label', ''), pure.sum(),
            fmt(mean), pct(std / mean), pct(hf / mean), np.sqrt((others ** 2).mean())))


if __name__ == '__main__':
    main()
