#!/usr/bin/env python3
"""ply2obj.py MESH.ply OUT.obj SCENE.json OUT.json -- the same mesh as an OBJ
file (v and f lines, 9 significant digits: the same floats), and a copy of its benchmark
scene that loads the OBJ, so `make bench` times both formats' whole path."""
import json
import struct
import sys

ply, obj, scene, out = sys.argv[1:5]
data = open(ply, "rb").read()
end = data.index(b"end_header") + len(b"end_header")
end = data.index(b"\n", end) + 1
header = data[:end].decode("ascii").split("\n")
nv = nf = 0
for line in header:
    w = line.split()
    if w[:2] == ["element", "vertex"]:
        nv = int(w[2])
    elif w[:2] == ["element", "face"]:
        nf = int(w[2])
assert "format binary_little_endian 1.0" in header, "genmesh writes binary little-endian PLY"
# genmesh: float x y z per vertex; uchar count + uint indices per face
verts = struct.unpack_from("<%df" % (3 * nv), data, end)
at = end + 12 * nv
with open(obj, "w") as f:
    f.write("# %d vertices, %d triangles (from %s)\n" % (nv, nf, ply.split("/")[-1]))
    for i in range(nv):
        f.write("v %.9g %.9g %.9g\n" % verts[3 * i:3 * i + 3])
    for _ in range(nf):
        n = data[at]
        idx = struct.unpack_from("<%dI" % n, data, at + 1)
        at += 1 + 4 * n
        f.write("f " + " ".join(str(k + 1) for k in idx) + "\n")
s = json.load(open(scene))
for o in s["objects"]:
    if o.get("type") == "mesh":
        o["source"] = {"file": obj.split("/")[-1], "format": "obj"}
json.dump(s, open(out, "w"), indent=1)
