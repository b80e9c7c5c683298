#!/usr/bin/env python3
"""scripts/mitsuba_capture.py with a second material set, as in issue 24's
fourth independent capture: a glazed ceramic (a smooth clear glaze over an
off-white body: roughplastic, GGX, alpha 0.04, ior 1.5), polished copper
(roughconductor, GGX, alpha 0.12, Johnson & Christy eta/k) and a blue matte
paint (diffuse). Takes mitsuba_capture.py's arguments, plus
`--ceiling-spp N`: render the held-out views again (independent seed, no
added noise) into truth/ceiling/, the truth's own relight, and
`--set metal`: mitsuba_capture.py's own materials (copper, red plastic,
green paint) instead of the ceramic set, with the same ceiling.

mitsuba_capture.py itself is left as it is: its source is part of the frozen
generalization benchmark's sampler hash (scripts/mitsuba_scenes.py).

    /work/scratch/mi/bin/python scripts/mitsuba_capture_ceramic.py --shape SCAN.obj --no-uvs \\
        --bounces 2 --heldout 12 --ceiling-spp 64 --out CAP
"""
import functools
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mitsuba_capture as mc  # noqa: E402


def ceramic_materials():
    ceramic = {"type": "roughplastic", "distribution": "ggx", "alpha": 0.04, "int_ior": 1.5, "ext_ior": 1.0,
               "diffuse_reflectance": {"type": "rgb", "value": [0.80, 0.76, 0.68]}, "nonlinear": False}
    copper = {"type": "roughconductor", "distribution": "ggx", "alpha": 0.12,
              "eta": {"type": "rgb", "value": mc.COPPER_ETA}, "k": {"type": "rgb", "value": mc.COPPER_K}}
    paint = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.12, 0.22, 0.45]}}
    return [("ceramic", ceramic), ("copper", copper), ("paint", paint)]


def main():
    ceiling_spp = 0
    if "--ceiling-spp" in sys.argv:
        i = sys.argv.index("--ceiling-spp")
        ceiling_spp = int(sys.argv[i + 1])
        del sys.argv[i:i + 2]
    material_set = "ceramic"
    if "--set" in sys.argv:
        i = sys.argv.index("--set")
        material_set = sys.argv[i + 1]
        del sys.argv[i:i + 2]
    if material_set not in ("ceramic", "metal"):
        sys.exit("mitsuba_capture_ceramic.py: --set must be ceramic or metal, got %r" % material_set)
    if material_set == "ceramic":
        mc.fixed_materials = ceramic_materials
    mc.render_capture = functools.partial(mc.render_capture, ceiling_spp=ceiling_spp)
    return mc.main()


if __name__ == "__main__":
    sys.exit(main())
