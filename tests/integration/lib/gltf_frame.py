#!/usr/bin/env python3
"""gltf_frame.py -- helpers of cli_gltf.sh (the standard library only).

  gltf_frame.py scene FILE   prints a rayd scene of FILE (.gltf or .glb) as a
                             mesh source, the camera framing its bounds: the
                             node tree of the default scene walked with each
                             node's matrix or TRS, each POSITION accessor's
                             min and max corners placed; a file that cannot
                             be read so gets the box -1..1
  gltf_frame.py lit PNG      prints how many pixels of an 8-bit PNG are not
                             the black background
  gltf_frame.py unlike_corner PNG   prints how many pixels differ from the
                             top-left one by more than 24 in a channel (an
                             object against a plain background; thumbnails.sh)
"""
import json
import math
import struct
import sys
import zlib


def load_doc(path):
    data = open(path, "rb").read()
    if data[:4] == b"glTF":
        n = struct.unpack_from("<I", data, 12)[0]
        return json.loads(data[20:20 + n])
    return json.loads(data)


def mul(a, b):  # column-major 4x4
    return [sum(a[k * 4 + r] * b[c * 4 + k] for k in range(4)) for c in range(4) for r in range(4)]


def local(n):
    if "matrix" in n:
        return [float(x) for x in n["matrix"]]
    t = n.get("translation", [0, 0, 0])
    x, y, z, w = n.get("rotation", [0, 0, 0, 1])
    s = n.get("scale", [1, 1, 1])
    r = [1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),
         2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
         2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)]
    m = []
    for c in range(3):
        m += [r[c * 3 + k] * s[c] for k in range(3)] + [0]
    return m + [t[0], t[1], t[2], 1]


def bounds(doc):
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    nodes = doc.get("nodes", [])
    scenes = doc.get("scenes", [])
    roots = scenes[doc.get("scene", 0)].get("nodes", []) if scenes else range(len(nodes))
    stack = [(i, [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], 0) for i in roots]
    while stack:
        i, pm, depth = stack.pop()
        if depth > 64:
            continue
        n = nodes[i]
        m = mul(pm, local(n))
        for p in doc["meshes"][n["mesh"]]["primitives"] if "mesh" in n else []:
            a = doc["accessors"][p["attributes"]["POSITION"]]
            amin, amax = a.get("min", [-1] * 3), a.get("max", [1] * 3)
            for k in range(8):
                v = [(amax if k >> j & 1 else amin)[j] for j in range(3)]
                for r in range(3):
                    q = m[r] * v[0] + m[4 + r] * v[1] + m[8 + r] * v[2] + m[12 + r]
                    lo[r], hi[r] = min(lo[r], q), max(hi[r], q)
        stack += [(c, m, depth + 1) for c in n.get("children", [])]
    if not all(math.isfinite(v) for v in lo + hi):
        raise ValueError("no finite bounds")
    return lo, hi


def scene(path):
    try:
        lo, hi = bounds(load_doc(path))
    except Exception:
        lo, hi = [-1] * 3, [1] * 3
    c = [(a + b) / 2 for a, b in zip(lo, hi)]
    r = max(math.dist(lo, hi) / 2, 1e-3)
    eye = [c[0] + 1.2 * r, c[1] + 1.0 * r, c[2] + 2.2 * r]
    print(json.dumps({
        "render": {"width": 64, "height": 48, "background": [0, 0, 0]},
        "camera": {"position": eye, "look_at": c, "up": [0, 1, 0], "fov_x": 60},
        "lights": [{"type": "point", "position": eye}],
        "objects": [{"type": "mesh", "source": {"file": path}}]}))


def rows(path):
    """The rows of an 8-bit PNG, unfiltered: (bytes per pixel, [bytearray])."""
    data = open(path, "rb").read()
    at, idat, w = 8, b"", 0
    while at < len(data):
        n, kind = struct.unpack_from(">I4s", data, at)
        body = data[at + 8:at + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype = struct.unpack_from(">IIBB", body)
            bpp = {2: 3, 6: 4, 0: 1, 4: 2}[ctype] * (depth // 8)
        elif kind == b"IDAT":
            idat += body
        at += 12 + n
    raw, out, prev = zlib.decompress(idat), [], bytearray(w * bpp)
    stride = w * bpp + 1
    for y in range(h):
        f, line = raw[y * stride], bytearray(raw[y * stride + 1:(y + 1) * stride])
        for x in range(len(line)):
            a = line[x - bpp] if x >= bpp else 0
            b = prev[x]
            c = prev[x - bpp] if x >= bpp else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + b) & 255
            elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        out.append(line)
        prev = line
    return bpp, out


def lit(path):
    bpp, lines = rows(path)
    w = len(lines[0]) // bpp if lines else 0
    print(sum(1 for line in lines for x in range(w) if max(line[x * bpp:x * bpp + min(bpp, 3)]) > 8))


def unlike_corner(path):
    """Pixels that differ from the top-left one by more than 24 in a channel:
    an object seen against a plain background."""
    bpp, lines = rows(path)
    w = len(lines[0]) // bpp if lines else 0
    ref = lines[0][:3]
    print(sum(1 for line in lines for x in range(w)
              if max(abs(line[x * bpp + k] - ref[k]) for k in range(3)) > 24))


if __name__ == "__main__":
    {"scene": scene, "lit": lit, "unlike_corner": unlike_corner}[sys.argv[1]](sys.argv[2])
