#!/usr/bin/env python3
"""make_studio_hdr.py -- writes scenes/studio.hdr, a neutral studio environment.

    python3 tools/make_studio_hdr.py [OUT.hdr]    (default scenes/studio.hdr)
    python3 tools/make_studio_hdr.py --scene      and writes scenes/studio.json,
                                                  which embeds it (base64)

A 32 x 16 equirectangular Radiance .hdr in rayd's layout (row 0 looks
straight up, the centre column looks down -Z), grey, with no colour so that
a model shows its own: a soft, broad top light (radiance 4 straight up,
falling smoothly to the walls' level 50 degrees from the zenith), grey
walls a little brighter at the horizon, and a darker grey floor.  No sun
and no randomness, so the bytes never change and a render is soft and
quiet at a few samples; 2 KiB.  rayd-client thumbnails embeds the same
image (clients/studio_hdr.h is generated from it by this script).

The example scene, scenes/studio.json, is a small vase (a surface of
revolution, written here as OBJ text) on a floor plane, lit by the image
alone and framed with "camera": {"frame": "all"}: the plane is unbounded,
so the framing sees the vase only.
"""
import base64
import json
import math
import sys

W, H = 32, 16


def direction(i, j):
    theta = math.pi * (j + 0.5) / H
    phi = 2 * math.pi * ((i + 0.5) / W - 0.5)
    return (math.sin(theta) * math.sin(phi), math.cos(theta), -math.sin(theta) * math.cos(phi))


def radiance(d):
    y = d[1]
    if y < 0:  # the floor
        g = 0.18 + 0.1 * (1 + y)
        return (g, g, g)
    wall = 0.55 + 0.25 * (1 - y)  # brighter toward the horizon
    zen = math.degrees(math.acos(min(1.0, y)))
    t = max(0.0, 1 - zen / 50)  # 1 at the zenith, 0 from 50 degrees down
    g = wall + (4.0 - wall) * t * t * (3 - 2 * t)
    return (g, g, g)


def rgbe(c):
    v = max(c)
    if v < 1e-32:
        return bytes(4)
    m, e = math.frexp(v)
    scale = m * 256.0 / v
    return bytes([int(c[0] * scale), int(c[1] * scale), int(c[2] * scale), e + 128])


def hdr():
    data = bytearray(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (H, W))
    for j in range(H):
        for i in range(W):
            data += rgbe(radiance(direction(i, j)))
    return bytes(data)


def vase_obj(segments=16):
    """A closed-bottom vase: a profile (radius, height) turned about +Y."""
    profile = [(0.0, 0.0), (0.45, 0.0), (0.6, 0.3), (0.55, 0.8), (0.3, 1.2), (0.28, 1.5), (0.38, 1.7)]
    lines = []
    for r, y in profile:
        for k in range(segments if r > 0 else 1):
            a = 2 * math.pi * k / segments
            lines.append("v %.4g %.4g %.4g" % (r * math.sin(a), y, r * math.cos(a)))
    for ring in range(1, len(profile) - 1):
        a0, b0 = 2 + (ring - 1) * segments, 2 + ring * segments
        for k in range(segments):
            k1 = (k + 1) % segments
            lines.append("f %d %d %d %d" % (a0 + k, a0 + k1, b0 + k1, b0 + k))
    for k in range(segments):  # the bottom: a fan from the centre (vertex 1)
        lines.append("f 1 %d %d" % (2 + (k + 1) % segments, 2 + k))
    return "\n".join(lines) + "\n"


def scene(image):
    return {
        "camera": {"frame": "all", "view": "three-quarter", "fov_y": 35},
        "render": {"width": 160, "height": 160, "samples": 16, "max_depth": 3, "integrator": "path",
                   "environment": {"base64": base64.b64encode(image).decode()}},
        "materials": {
            "glaze": {"color": [0.75, 0.35, 0.25], "specular": 0.3, "shininess": 40},
            "floor": {"color": [0.6, 0.6, 0.6]},
        },
        "objects": [
            {"type": "plane", "normal": [0, 1, 0], "material": "floor"},
            {"type": "mesh", "name": "vase", "material": "glaze", "smooth": True,
             "source": {"format": "obj", "text": vase_obj()}},
        ],
    }


def main():
    args = [a for a in sys.argv[1:] if a != "--scene"]
    out = args[0] if args else "scenes/studio.hdr"
    image = hdr()
    with open(out, "wb") as f:
        f.write(image)
    if "--scene" in sys.argv[1:]:
        with open("scenes/studio.json", "w") as f:
            f.write(json.dumps(scene(image), indent=1) + "\n")


if __name__ == "__main__":
    main()
