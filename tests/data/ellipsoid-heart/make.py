"""Makes the synthetic ellipsoid heart of this folder (run once; the outputs
are committed). Needs numpy and meshio (pip install numpy meshio).

A left ventricle as a truncated thick prolate ellipsoid, apex at -z, base a
plane: the wall between the outer (epicardium) and inner (endocardium)
ellipsoids, semi-axes (A, A, C) scaled by s in [S_IN, 1]. Vertices on K rings
of polar angle t in (0, T_MAX] (t = 0 the apex) with M points each, on L
layers from the inside out; the prisms between layers over the surface
triangles split into 3 tets by vertex order (conforming), all positively
oriented.

- heart.vtu: the wall's tets, written by meshio (VTK XML, zlib-compressed
  binary), cell array Material = 31;
- epi.obj: the outer layer's triangles (the epicardium: a disk whose rim is
  planar), every second triangle reversed, as files from other tools often
  are (the pipeline repairs it).
"""

import numpy as np
import meshio

A, C = 25.0, 50.0
S_IN = 0.7
T_MAX = np.deg2rad(100.0)
K, M, L = 20, 48, 4


def surface():
    pts = [(0.0, 0.0, -1.0)]
    for k in range(1, K + 1):
        t = T_MAX * k / K
        for j in range(M):
            p = 2 * np.pi * j / M
            pts.append((np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), -np.cos(t)))
    tris = []
    ring = lambda k, j: 1 + (k - 1) * M + j % M
    for j in range(M):
        tris.append((0, ring(1, j), ring(1, j + 1)))
    for k in range(1, K):
        for j in range(M):
            a, b = ring(k, j), ring(k, j + 1)
            c, d = ring(k + 1, j), ring(k + 1, j + 1)
            tris.append((a, c, d))
            tris.append((a, d, b))
    return np.array(pts), np.array(tris)


def main():
    unit, tris = surface()
    n = len(unit)
    layers = []
    for i in range(L):
        s = S_IN + (1.0 - S_IN) * i / (L - 1)
        layers.append(unit * np.array([A * s, A * s, C * s]))
    points = np.vstack(layers)
    tets = []
    for i in range(L - 1):
        lo, hi = i * n, (i + 1) * n
        for tri in tris:
            a, b, c = sorted(tri)
            for t in ((a + lo, b + lo, c + lo, a + hi),
                      (b + lo, c + lo, a + hi, b + hi),
                      (c + lo, a + hi, b + hi, c + hi)):
                p = points[list(t)]
                if np.linalg.det(np.array([p[1] - p[0], p[2] - p[0], p[3] - p[0]])) < 0:
                    t = (t[0], t[2], t[1], t[3])
                tets.append(t)
    tets = np.array(tets)
    meshio.write(
        "heart.vtu",
        meshio.Mesh(points, [("tetra", tets)],
                    cell_data={"Material": [np.full(len(tets), 31, dtype=np.int32)]}),
        binary=True, compression="zlib",
    )
    outer = (L - 1) * n
    with open("epi.obj", "w") as f:
        f.write("# synthetic ellipsoid epicardium (see make.py)\n")
        for p in layers[-1]:
            f.write("v %.9g %.9g %.9g\n" % tuple(p))
        for k, (a, b, c) in enumerate(tris):
            if k % 2:
                a, b = b, a
            f.write("f %d %d %d\n" % (a + 1, b + 1, c + 1))
    print(len(points), "points,", len(tets), "tets;", len(tris), "epicardium triangles")


if __name__ == "__main__":
    main()
