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
import argparse, json, os, sys
import numpy as np
import OpenImageIO as oiio

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from texel_resample import resize  # noqa: E402


def load(path):
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise SystemExit('weight_error: cannot read %s' % path)
    a = np.array(inp.read_image(format='float'), dtype=np.float64)
    inp.close()
    return a if a.ndim == 3 else a[..., None]


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
