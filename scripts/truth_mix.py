#!/usr/bin/env python3
"""Material folder mixing the basis materials, mixing weights and normal map
of different folders (a reconstruction and a synthetic capture's gt/), so
that `svbrdf relight` + `svbrdf evaluate` split a reconstruction's held-out
error into its parts: relight the TRUE material with the TRUE normals (the
renderer's ceiling), with mesh normals, with the reconstruction's normals;
the reconstruction's basis with the true weights and normals; and so on
(bench_results/mixed.md, "Where the error goes").

Maps are resampled bilinearly (texel centres) to the output resolution;
normals renormalised. The normal map keeps its material.json
"normal_map_space" (world: synth's ground truth; tangent: reconstruct's);
--normals-on refuses to mix maps of different spaces (their numbers mean
different normals). The mesh (and its UVs) come from the weights folder,
so both folders must share the mesh's texture coordinates (a synthetic
capture's reconstruction with the capture's UVs does).

Usage (a Python with numpy and Mitsuba 3 for EXR input/output, as
scripts/mitsuba_truth_material.py):
  truth_mix.py OUT --basis DIR --weights DIR [--perm 2,1,0] --normals DIR|none
               [--res N] [--normals-on DIR:k]
    --perm       output weight k = the weights folder's weight perm[k]
                 (matches a reconstruction's basis order to the truth's)
    --normals-on DIR:k  the normal map of DIR replaces the --normals one
                 where DIR's weight k > 0.5 (one material's normals swapped)
Example:
  truth_mix.py mix --basis rec --weights CAP/gt --perm 2,1,0 --normals CAP/gt --res 128
  svbrdf relight mix CAP/heldout/scene.json --out relit && svbrdf evaluate relit CAP/heldout/scene.json
"""
import argparse, json, os, shutil, sys
import mitsuba as mi
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from texel_resample import resize  # noqa: E402

mi.set_variant('scalar_rgb')


def load(path):
    return np.array(mi.Bitmap(path)).astype(np.float64)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('out')
    ap.add_argument('--basis', required=True)
    ap.add_argument('--weights', required=True)
    ap.add_argument('--normals', required=True)
    ap.add_argument('--res', type=int, default=0)
    ap.add_argument('--perm', default='')
    ap.add_argument('--normals-on', default='')
    a = ap.parse_args()
    mb = json.load(open(a.basis + '/material.json'))
    mw = json.load(open(a.weights + '/material.json'))
    R = a.res or mw['resolution'][0]
    if len(mb['basis']) != len(mw['basis']):
        raise SystemExit('truth_mix: %s has %d basis materials, %s %d' % (a.basis, len(mb['basis']), a.weights, len(mw['basis'])))
    os.makedirs(a.out + '/weights', exist_ok=True)
    shutil.copy(a.weights + '/mesh.obj', a.out + '/mesh.obj')
    files = mw['weights']
    if a.perm:
        files = [files[int(i)] for i in a.perm.split(',')]
    for k, f in enumerate(files):
        mi.Bitmap(resize(load(a.weights + '/' + f), R).astype(np.float32)).write(a.out + '/weights/m%d.exr' % k)
    m = {'format': 'svbrdf-material/1', 'mesh': 'mesh.obj', 'resolution': [R, R], 'basis': mb['basis'],
         'weights': ['weights/m%d.exr' % k for k in range(len(files))]}
    if a.normals != 'none':
        mn = json.load(open(a.normals + '/material.json'))
        if 'normal_map' not in mn:
            raise SystemExit('truth_mix: %s has no normal_map' % a.normals)
        n = resize(load(a.normals + '/' + mn['normal_map']), R)
        space = mn.get('normal_map_space', 'world')
        if a.normals_on:
            d, k = a.normals_on.split(':')
            md = json.load(open(d + '/material.json'))
            if md.get('normal_map_space', 'world') != space:
                raise SystemExit('truth_mix: %s/material.json normal_map_space is %s, %s/material.json %s: cannot mix them'
                                 % (d, md.get('normal_map_space', 'world'), a.normals, space))
            w = resize(load(d + '/' + md['weights'][int(k)]), R)[..., 0]
            swap = resize(load(d + '/' + md['normal_map']), R)
            n[w > 0.5] = swap[w > 0.5]
        n /= np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-9)
        mi.Bitmap(n.astype(np.float32)).write(a.out + '/normal.exr')
        m['normal_map'] = 'normal.exr'
        if space != 'world':
            m['normal_map_space'] = space
    json.dump(m, open(a.out + '/material.json', 'w'), indent=1)


if __name__ == '__main__':
    main()
