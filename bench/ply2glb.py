#!/usr/bin/env python3
"""ply2glb.py -- a binary little-endian PLY of float x y z and triangle faces
(what bench/genmesh writes) as a .glb holding the same vertices and
triangles: one node, one mesh, one indexed primitive (UNSIGNED_INT), one
buffer in the BIN chunk.  For comparing the glTF reader with the PLY reader
on the same mesh (bench/gltf.sh).

  ply2glb.py IN.ply OUT.glb
"""
import json
import struct
import sys


def main(src, dst):
    data = open(src, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    head = data[:end].decode().split("\n")
    nv = int(next(l for l in head if l.startswith("element vertex")).split()[2])
    nf = int(next(l for l in head if l.startswith("element face")).split()[2])
    pos = data[end:end + 12 * nv]
    faces = memoryview(data)[end + 12 * nv:]
    if len(faces) != 13 * nf:
        sys.exit("ply2glb: expected triangles of 'list uchar uint' only")
    idx = bytearray(12 * nf)
    for k in range(3):  # the three uints of every 13-byte record, strided
        for b in range(4):
            idx[4 * k + b::12] = faces[1 + 4 * k + b::13]
    xs = struct.unpack("<%df" % (3 * nv), pos)
    lo = [min(xs[i::3]) for i in range(3)]
    hi = [max(xs[i::3]) for i in range(3)]
    doc = {"asset": {"version": "2.0", "generator": "rayd bench/ply2glb.py"},
           "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
           "buffers": [{"byteLength": len(pos) + len(idx)}],
           "bufferViews": [{"buffer": 0, "byteLength": len(pos), "target": 34962},
                           {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx), "target": 34963}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3",
                          "min": lo, "max": hi},
                         {"bufferView": 1, "componentType": 5125, "count": 3 * nf, "type": "SCALAR"}]}
    j = json.dumps(doc).encode()
    j += b" " * (-len(j) % 4)
    binb = pos + bytes(idx)
    total = 12 + 8 + len(j) + 8 + len(binb)
    with open(dst, "wb") as f:
        f.write(b"glTF" + struct.pack("<II", 2, total))
        f.write(struct.pack("<I", len(j)) + b"JSON" + j)
        f.write(struct.pack("<I", len(binb)) + b"BIN\0" + binb)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
