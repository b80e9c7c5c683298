#!/usr/bin/env python3
"""Our basis materials with the truth's mixing weights: separates the error
of the weights from the error of the basis materials on a capture of
scripts/mitsuba_scenes.py (per-vertex truth weights, truth/vertex_weights.npy).

The truth weights are rasterised into the reconstruction's atlas at texel
centres (barycentric, as Mitsuba interpolates them), each true material is
matched to the basis material that overlaps it most (true materials that
match the same one add), texels no triangle covers keep the reconstruction's
weights. Prints per basis material the mean |ours - truth| and the same over
blend texels (0.05 < truth < 0.95), then writes a copy of the material folder
with the truth's weights; relight and evaluate it to score it:

  /work/scratch/mi/bin/python scripts/mitsuba_truth_weights.py REC/material CAP OUT
  svbrdf relight OUT CAP/heldout/scene.json --out RELIT --bounces 2
  svbrdf evaluate RELIT CAP/heldout/scene.json
"""
import json, os, shutil, sys
import numpy as np


def rasterise_vertex_weights(material_dir, w):
    """Per-vertex weights w (V x K) of the material folder's mesh.obj at its
    atlas' texel centres: (H x W x K array, H x W mask of covered texels)."""
    VT, F, FT = [], [], []
    for line in open(os.path.join(material_dir, 'mesh.obj')):
        p = line.split()
        if not p:
            continue
        if p[0] == 'vt':
            VT.append([float(x) for x in p[1:3]])
        elif p[0] == 'f':
            a = [q.split('/') for q in p[1:]]
            F.append([int(q[0]) - 1 for q in a])
            FT.append([int(q[1]) - 1 for q in a])
    VT, F, FT = np.array(VT), np.array(F), np.array(FT)
    W, H = json.load(open(os.path.join(material_dir, 'material.json')))['resolution']
    acc = np.zeros((H, W, w.shape[1]))
    cnt = np.zeros((H, W))
    for f, ft in zip(F, FT):
        uv = VT[ft]
        P = np.stack([uv[:, 0] * W, (1 - uv[:, 1]) * H], 1)
        x0, y0 = np.floor(P.min(0) - 0.5).astype(int)
        x1, y1 = np.ceil(P.max(0) + 0.5).astype(int)
        xs, ys = np.meshgrid(np.arange(max(x0, 0), min(x1 + 1, W)), np.arange(max(y0, 0), min(y1 + 1, H)))
        c = np.stack([xs + 0.5, ys + 0.5], -1).reshape(-1, 2)
        T = np.array([P[1] - P[0], P[2] - P[0]]).T
        if abs(np.linalg.det(T)) < 1e-12:
            continue
        b = np.linalg.solve(T, (c - P[0]).T).T
        b0 = 1 - b.sum(1)
        ok = (b[:, 0] >= -0.3) & (b[:, 1] >= -0.3) & (b0 >= -0.3)
        bb = np.clip(np.stack([b0, b[:, 0], b[:, 1]], 1), 0, 1)
        bb /= bb.sum(1, keepdims=True)
        val = bb @ w[f]
        for (cx, cy), v, o in zip(c.astype(int), val, ok):
            if o:
                acc[cy, cx] += v
                cnt[cy, cx] += 1
    m = cnt > 0
    acc[m] /= cnt[m][:, None]
    return acc, m


def main():
    import mitsuba as mi
    mi.set_variant('scalar_rgb')
    src, cap, out = sys.argv[1:4]
    w = np.load(os.path.join(cap, 'truth', 'vertex_weights.npy'))
    if w.ndim == 1:
        w = w[:, None]
    truth, m = rasterise_vertex_weights(src, w)
    mat = json.load(open(os.path.join(src, 'material.json')))
    ours = [np.array(mi.Bitmap(os.path.join(src, p)))[..., 0] for p in mat['weights']]
    K = len(ours)
    overlap = np.array([[(truth[..., i] * ours[k])[m].sum() for k in range(K)] for i in range(w.shape[1])])
    match = [int(np.argmax(row)) for row in overlap]
    print('true material -> basis material:', match)
    new = np.zeros(ours[0].shape + (K,))
    for i, k in enumerate(match):
        new[..., k] += truth[..., i]
    for k in range(K):
        o, t = ours[k], new[..., k]
        sel = m & (np.maximum(o, t) > 0.02)
        blend = m & (t > 0.05) & (t < 0.95)
        print('m%d: |ours - truth| mean %.3f over %d texels; blend texels %d, mean %.3f there' % (
            k, np.abs(o - t)[sel].mean(), sel.sum(), blend.sum(), np.abs(o - t)[blend].mean() if blend.any() else 0))
        t[~m] = o[~m]
    shutil.rmtree(out, ignore_errors=True)
    shutil.copytree(src, out)
    for k, p in enumerate(mat['weights']):
        mi.Bitmap(np.repeat(new[..., k:k + 1], 3, 2).astype(np.float32)).write(os.path.join(out, p))


if __name__ == '__main__':
    main()
