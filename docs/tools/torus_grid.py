#!/usr/bin/env python3
"""A torus grid of 2*nu*nv triangles as OBJ (text) and binary little-endian PLY.
usage: torus_grid.py NU NV OUT_PREFIX   (2500 2000 gives 10M triangles; numpy if present, else pure Python)"""
import math, struct, sys, time
from array import array
nu, nv, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
t0 = time.time()
R, r = 1.0, 0.35
try:
    import numpy as np
    u = np.arange(nu) * (2 * math.pi / nu)
    v = np.arange(nv) * (2 * math.pi / nv)
    U, V = np.meshgrid(u, v, indexing="ij")
    X = ((R + r * np.cos(V)) * np.cos(U)).ravel().astype(np.float32)
    Y = ((R + r * np.cos(V)) * np.sin(U)).ravel().astype(np.float32)
    Z = (r * np.sin(V)).ravel().astype(np.float32)
    verts = np.stack([X, Y, Z], axis=1)
    i = np.arange(nu).repeat(nv); j = np.tile(np.arange(nv), nu)
    a = i * nv + j; b = ((i + 1) % nu) * nv + j; c = ((i + 1) % nu) * nv + (j + 1) % nv; d = i * nv + (j + 1) % nv
    faces = np.empty((2 * nu * nv, 3), dtype=np.int32)
    faces[0::2] = np.stack([a, b, c], axis=1); faces[1::2] = np.stack([a, c, d], axis=1)
    with open(out + ".ply", "wb") as f:
        f.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n".encode())
        f.write(verts.tobytes())
        rec = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", 3)]); rec["n"] = 3; rec["i"] = faces
        f.write(rec.tobytes())
    with open(out + ".obj", "w") as f:
        np.savetxt(f, verts, fmt="v %.6f %.6f %.6f")
        np.savetxt(f, faces + 1, fmt="f %d %d %d")
except ImportError:
    with open(out + ".obj", "w") as fo, open(out + ".ply", "wb") as fp:
        n = nu * nv
        fp.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\nelement face {2*n}\nproperty list uchar int vertex_indices\nend_header\n".encode())
        for i in range(nu):
            cu, su = math.cos(2 * math.pi * i / nu), math.sin(2 * math.pi * i / nu)
            vs = array("f")
            lines = []
            for j in range(nv):
                cv, sv = math.cos(2 * math.pi * j / nv), math.sin(2 * math.pi * j / nv)
                x, y, z = (R + r * cv) * cu, (R + r * cv) * su, r * sv
                vs.extend((x, y, z)); lines.append("v %.6f %.6f %.6f\n" % (x, y, z))
            fp.write(vs.tobytes()); fo.write("".join(lines))
        for i in range(nu):
            lines = []; buf = bytearray()
            for j in range(nv):
                a = i * nv + j; b = ((i + 1) % nu) * nv + j; c = ((i + 1) % nu) * nv + (j + 1) % nv; d = i * nv + (j + 1) % nv
                lines.append("f %d %d %d\nf %d %d %d\n" % (a + 1, b + 1, c + 1, a + 1, c + 1, d + 1))
                buf += struct.pack("<BiiiBiii", 3, a, b, c, 3, a, c, d)
            fo.write("".join(lines)); fp.write(buf)
print(f"wrote {out}.obj and {out}.ply: {2*nu*nv} triangles in {time.time()-t0:.1f} s", file=sys.stderr)
