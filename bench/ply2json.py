#!/usr/bin/env python3
"""ply2json.py SCENE.json OUT.json -- the same scene with its PLY mesh inline.

Takes a scene from mkscene.py (one mesh object whose "source" names a
binary or ascii PLY next to the scene) and writes it with the mesh as flat
inline arrays, "vertices" (7 significant digits, enough for a float) and
"indices", as a client would send it: the benchmark of the loader's inline
path against the PLY decoder on the same mesh.  Faces must be triangles.
"""
import json
import os
import struct
import sys

TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
         "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
         "float": "f", "float32": "f", "double": "d", "float64": "d"}


def read_ply(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header") + len(b"end_header")
    end = data.index(b"\n", end) + 1
    fmt, elems = None, []
    for line in data[:end].decode("ascii").splitlines():
        w = line.split()
        if w and w[0] == "format":
            fmt = w[1]
        elif w and w[0] == "element":
            elems.append([w[1], int(w[2]), []])
        elif w and w[0] == "property":
            elems[-1][2].append(w[1:])
    if fmt == "ascii":
        sys.exit("ply2json: ascii PLY not supported; convert it to binary")
    order = "<" if fmt == "binary_little_endian" else ">"
    pos, verts, tris = end, [], []
    for name, count, props in elems:
        if name == "vertex":
            rec = struct.Struct(order + "".join(TYPES[p[0]] for p in props))
            names = [p[1] for p in props]
            ix = [names.index(c) for c in "xyz"]
            for k in range(count):
                v = rec.unpack_from(data, pos + k * rec.size)
                verts.extend(v[i] for i in ix)
            pos += count * rec.size
        elif name == "face":
            cnt, idx = struct.Struct(order + TYPES[props[0][1]]), struct.Struct(order + TYPES[props[0][2]])
            for _ in range(count):
                (n,) = cnt.unpack_from(data, pos)
                pos += cnt.size
                if n != 3:
                    sys.exit("ply2json: a face is not a triangle")
                tris.extend(struct.unpack_from(order + TYPES[props[0][2]] * 3, data, pos))
                pos += 3 * idx.size
    return verts, tris


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: ply2json.py SCENE.json OUT.json")
    scene = json.load(open(sys.argv[1]))
    obj = scene["objects"][0]
    verts, tris = read_ply(os.path.join(os.path.dirname(sys.argv[1]), obj.pop("source")["file"]))
    with open(sys.argv[2], "w") as f:
        head = json.dumps(scene)[:-3]  # up to the mesh object's closing "}]}"
        f.write(head + ', "vertices": [' + ",".join("%.7g" % v for v in verts) + "]")
        f.write(', "indices": [' + ",".join(str(i) for i in tris) + "]}]}\n")


main()
