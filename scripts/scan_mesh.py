#!/usr/bin/python3
"""Real scanned meshes for tests and benchmarks, from Debian's CGAL data.

Debian's libcgal-demo ships CGAL's example data (data.tar.gz), among it real
scans such as the Stanford bunny (bunny00.off, 75 k triangles) and the
armadillo. This extracts one OFF mesh, optionally decimates it by vertex
clustering (a uniform grid; vertices in one cell merge to their mean, faces
that collapse are dropped) and writes an OBJ without texture coordinates.

Usage:
  scripts/scan_mesh.py bunny00 --out bunny.obj                # full scan
  scripts/scan_mesh.py bunny00 --faces 4000 --out small.obj   # decimated
  scripts/scan_mesh.py --list
"""
import argparse
import io
import sys
import tarfile

import numpy as np

DATA = ["/usr/share/doc/libcgal-dev/data.tar.gz", "/usr/share/doc/libcgal-demo/data.tar.gz"]


def open_data():
    for path in DATA:
        try:
            return tarfile.open(path)
        except OSError:
            pass
    sys.exit("scan_mesh: CGAL data not found (apt-get install libcgal-demo): " + ", ".join(DATA))


def read_off(text):
    tokens = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            tokens.extend(line.split())
    if not tokens or not tokens[0].endswith("OFF"):
        sys.exit("scan_mesh: not an OFF file")
    nv, nf = int(tokens[1]), int(tokens[2])
    pos = np.array(tokens[4:4 + 3 * nv], dtype=float).reshape(nv, 3)
    faces, i = [], 4 + 3 * nv
    for _ in range(nf):
        n = int(tokens[i])
        idx = [int(t) for t in tokens[i + 1:i + 1 + n]]
        i += 1 + n
        for k in range(1, n - 1):  # fan-triangulate polygons
            faces.append((idx[0], idx[k], idx[k + 1]))
    return pos, np.array(faces, dtype=np.int64)


def decimate(pos, faces, target_faces):
    """Vertex clustering on a grid whose cell size is found by bisection."""
    lo, hi = pos.min(0), pos.max(0)
    extent = (hi - lo).max()
    best = (pos, faces)
    a, b = 4, 2048  # cells along the longest side
    for _ in range(14):
        cells = (a + b) // 2
        key = np.floor((pos - lo) / extent * cells).astype(np.int64)
        _, inverse = np.unique(key[:, 0] * cells * cells * 4 + key[:, 1] * cells * 2 + key[:, 2], return_inverse=True)
        f = inverse[faces]
        f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
        f = np.unique(f, axis=0)
        if len(f) > target_faces:
            b = cells
        else:
            a = cells
            count = np.bincount(inverse, minlength=inverse.max() + 1)[:, None]
            p = np.zeros((inverse.max() + 1, 3))
            np.add.at(p, inverse, pos)
            best = (p / count, f)
        if b - a <= 1:
            break
    p, f = best
    used = np.unique(f)
    remap = -np.ones(len(p), dtype=np.int64)
    remap[used] = np.arange(len(used))
    return p[used], remap[f]


def load(name, target_faces=0):
    """Positions and triangles of CGAL's data/meshes/<name>.off, decimated to at most target_faces (0 = all)."""
    member = open_data().extractfile("data/meshes/%s.off" % name)
    pos, faces = read_off(io.TextIOWrapper(member, encoding="ascii", errors="replace").read())
    if target_faces and len(faces) > target_faces:
        pos, faces = decimate(pos, faces, target_faces)
    return pos, faces


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("name", nargs="?", help="mesh name in CGAL's data/meshes (e.g. bunny00, armadillo)")
    ap.add_argument("--faces", type=int, default=0, help="decimate to at most this many triangles (0 = keep all)")
    ap.add_argument("--out", help="output OBJ")
    ap.add_argument("--list", action="store_true", help="list the meshes in the data")
    a = ap.parse_args()
    tar = open_data()
    if a.list:
        for m in tar.getmembers():
            if m.name.startswith("data/meshes/") and m.name.endswith(".off"):
                print(m.name[len("data/meshes/"):-4], m.size)
        return
    if not a.name or not a.out:
        ap.error("name and --out are needed")
    pos, faces = load(a.name, a.faces)
    with open(a.out, "w") as out:
        out.write("# %s from CGAL's data (Debian libcgal-demo), %d triangles\n" % (a.name, len(faces)))
        out.write("".join("v %.6g %.6g %.6g\n" % tuple(p) for p in pos))
        out.write("".join("f %d %d %d\n" % (f[0] + 1, f[1] + 1, f[2] + 1) for f in faces))
    print("%s: %d vertices, %d triangles -> %s" % (a.name, len(pos), len(faces), a.out))


if __name__ == "__main__":
    main()
