#!/usr/bin/env python3
"""The true material of a scripts/mitsuba_capture.py capture as a material
folder on the UV atlas of a reconstructed one, so that `svbrdf relight` shows
the ceiling of our renderer on that capture (what a perfect reconstruction
would score). Per-vertex truth weights (truth/vertex_weights.npy) are
rasterised into the atlas at texel centres and dilated 3 texels (like the
reconstruction's atlas); basis: copper as conductor-ggx (exact eta, kappa,
alpha 0.2), paint as lambert, and the red roughplastic as the coated-ggx that
the sphere capture fits (our coated model is not Mitsuba's roughplastic with
nonlinear=false, so its true parameters do not render the same).

Usage (Mitsuba venv for numpy and EXR writing):
  /work/scratch/mi/bin/python scripts/mitsuba_truth_material.py MATERIAL CAPTURE OUT
  svbrdf relight OUT CAPTURE/heldout/scene.json --out RELIT --spp 4
"""
import mitsuba as mi, numpy as np, sys, json, os, shutil
mi.set_variant('scalar_rgb')
src, cap, out = sys.argv[1:4]
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_truth_weights import rasterise_vertex_weights  # noqa: E402
w=np.load(cap+'/truth/vertex_weights.npy')
mat=json.load(open(src+'/material.json'))
W,H=mat['resolution']
acc,m=rasterise_vertex_weights(src,w)
for it in range(3):
    fill=np.zeros_like(acc); fc=np.zeros((H,W))
    for dy in (-1,0,1):
        for dx in (-1,0,1):
            fill+=np.roll(np.roll(acc*m[...,None],dy,0),dx,1); fc+=np.roll(np.roll(m.astype(float),dy,0),dx,1)
    new=(~m)&(fc>0); acc[new]=fill[new]/fc[new][:,None]; m=m|new
os.makedirs(out+'/weights',exist_ok=True)
shutil.copy(src+'/mesh.obj',out+'/mesh.obj')
ETA=[0.27105,0.67693,1.31640];K=[3.60920,2.62480,2.29210]
basis=[{"name":"m0","model":"conductor","label":"conductor-ggx","params":{"eta_r":ETA[0],"eta_g":ETA[1],"eta_b":ETA[2],"kappa_r":K[0],"kappa_g":K[1],"kappa_b":K[2],"roughness":0.2}},
 {"name":"m1","model":"coated","label":"coated-ggx","params":{"rd_r":0.7065,"rd_g":0.1258,"rd_b":0.0865,"roughness":0.1003,"ior":1.4987}},
 {"name":"m2","model":"lambert","label":"lambert","params":{"rd_r":0.10,"rd_g":0.42,"rd_b":0.14}}]
for k in range(3):
    img=np.repeat(acc[...,k:k+1],3,2).astype(np.float32)
    mi.Bitmap(img).write(out+'/weights/m%d.exr'%k)
mj={"format":"svbrdf-material/1","mesh":"mesh.obj","resolution":[W,H],"basis":basis,"weights":["weights/m%d.exr"%k for k in range(3)]}
json.dump(mj,open(out+'/material.json','w'),indent=1)
print('texels',m.sum())
