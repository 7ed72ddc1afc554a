#!/usr/bin/env python3
"""mkscene.py MESH.ply OUT.json -- a benchmark scene that frames one mesh.

Reads the PLY's vertex positions (ascii or binary, x/y/z as the first
three float properties), takes the bounding box centre and the farthest
vertex from it as a bounding sphere, and writes a 1920x1080 scene: the
camera on +z looking at the centre with the sphere filling the frame's
height (fov_x 50), one point light up and to the right, a flat-shaded
mesh referenced by file (relative to the scene, as the loader wants).
Same PLY, same JSON: the numbers are rounded to 6 significant digits.
"""
import json
import math
import os
import struct
import sys

TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
         "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
         "float": "f", "float32": "f", "double": "d", "float64": "d"}


def vertices(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header") + len(b"end_header")
    end = data.index(b"\n", end) + 1
    header = data[:end].decode("ascii").splitlines()
    fmt, nverts, props, in_vertex = None, 0, [], False
    for line in header:
        w = line.split()
        if not w:
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            in_vertex = w[1] == "vertex"
            if in_vertex:
                nverts = int(w[2])
        elif w[0] == "property" and in_vertex:
            if w[1] == "list":
                sys.exit("mkscene: list property in vertex element")
            props.append((w[2], TYPES[w[1]]))
    names = [p[0] for p in props]
    ix = [names.index(c) for c in "xyz"]
    if fmt == "ascii":
        lines = data[end:].decode("ascii").split("\n")
        for k in range(nverts):
            v = lines[k].split()
            yield tuple(float(v[i]) for i in ix)
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        rec = struct.Struct(order + "".join(p[1] for p in props))
        for k in range(nverts):
            v = rec.unpack_from(data, end + k * rec.size)
            yield tuple(float(v[i]) for i in ix)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: mkscene.py MESH.ply OUT.json")
    ply, out = sys.argv[1], sys.argv[2]
    pts = list(vertices(ply))
    lo = [min(p[k] for p in pts) for k in range(3)]
    hi = [max(p[k] for p in pts) for k in range(3)]
    c = [(lo[k] + hi[k]) / 2 for k in range(3)]
    r = max(math.dist(p, c) for p in pts)
    w, h, fov_x = 1920, 1080, 50.0
    tan_y = math.tan(math.radians(fov_x / 2)) * h / w
    # The bounding sphere touches the top and bottom of the frame, plus 5%.
    d = 1.05 * r / math.sin(math.atan(tan_y))
    g = lambda v: float("%.6g" % v)
    scene = {
        "camera": {"position": [g(c[0]), g(c[1]), g(c[2] + d)], "look_at": [g(x) for x in c],
                   "up": [0, 1, 0], "fov_x": fov_x},
        "render": {"width": w, "height": h, "samples": 1, "max_depth": 5},
        "lights": [{"type": "point",
                    "position": [g(c[0] + 1.5 * r), g(c[1] + 2 * r), g(c[2] + 2.5 * r)]}],
        "objects": [{"type": "mesh", "source": {"file": os.path.basename(ply)}, "smooth": False,
                     "material": {"color": [0.8, 0.7, 0.6]}}],
    }
    with open(out, "w") as f:
        json.dump(scene, f)
        f.write("\n")


main()
