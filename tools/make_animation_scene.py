#!/usr/bin/env python3
"""make_animation_scene.py -- writes scenes/animation.json, the example of an
animated scene (docs/scene-format.md, "Animation").

    python3 tools/make_animation_scene.py [OUT.json]   (default scenes/animation.json)

Two seconds at 24 fps (frames 0-47): the camera circles a trefoil knot on
a smooth (Catmull-Rom) path through five keyframes, rising and sinking a
little; a point light moves across the sky and changes colour; the knot
turns 120 degrees (rotation keyframes, slerped) and a small sphere rolls
round it.  The knot is an inline mesh computed here (a tube of 128 x 10
quads round the (2, 3) torus knot), so the scene needs no file; every
number is computed, nothing random: the same script writes the same bytes.
Cheap to render (320 x 180, one sample, Whitted): `rayd-render
scenes/animation.json --video shot.mp4` takes seconds.
"""
import json
import math
import sys

P, Q, R, r, TUBE = 2, 3, 0.8, 0.3, 0.16
NU, NV = 128, 10


def knot(t):
    rr = R + r * math.cos(Q * t)
    return (rr * math.cos(P * t), r * math.sin(Q * t), rr * math.sin(P * t))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def unit(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def mesh():
    verts, idx = [], []
    for i in range(NU):
        t = 2 * math.pi * i / NU
        p, p2 = knot(t), knot(t + 1e-3)
        T = unit([p2[k] - p[k] for k in range(3)])
        N = unit(cross(T, (0, 1, 0)))
        B = cross(T, N)
        for j in range(NV):
            a = 2 * math.pi * j / NV
            c, s = math.cos(a) * TUBE, math.sin(a) * TUBE
            v = [p[k] + c * N[k] + s * B[k] for k in range(3)]
            verts += [round(v[0], 4), round(v[1] + 0.9, 4), round(v[2], 4)]
    for i in range(NU):
        for j in range(NV):
            a, d = i * NV + j, i * NV + (j + 1) % NV
            b, c = ((i + 1) % NU) * NV + j, ((i + 1) % NU) * NV + (j + 1) % NV
            idx += [a, b, c, a, c, d]
    return verts, idx


def scene():
    verts, idx = mesh()
    cam = []
    for f, ang in [(0, 0), (12, 90), (24, 180), (36, 270), (47, 352.5)]:
        a = math.radians(ang)
        cam.append({"frame": f, "position": [round(4.2 * math.sin(a), 4),
                                             round(1.9 + 0.5 * math.sin(a), 4),
                                             round(4.2 * math.cos(a), 4)]})
    return {
        "animation": {"start": 0, "end": 47, "fps": 24},
        "render": {"width": 320, "height": 180, "samples": 1, "max_depth": 3,
                   "background": [0.06, 0.07, 0.1]},
        "camera": {"look_at": [0, 0.8, 0], "fov_x": 50, "interpolation": "smooth", "keyframes": cam},
        "materials": {
            "knot": {"color": [0.85, 0.25, 0.12], "specular": 0.6, "shininess": 48},
            "floor": {"texture": {"type": "checker", "colors": [[0.75, 0.75, 0.72], [0.3, 0.3, 0.32]],
                                  "scale": 0.8}, "reflectivity": 0.15},
        },
        "lights": [
            {"type": "point", "interpolation": "smooth", "keyframes": [
                {"frame": 0, "position": [3, 4, 2], "color": [1, 0.95, 0.85], "intensity": 0.9},
                {"frame": 24, "position": [-3, 3, 3], "color": [0.85, 0.9, 1], "intensity": 1.1},
                {"frame": 47, "position": [-1, 4.5, -3], "color": [1, 0.95, 0.85], "intensity": 0.8}]},
            {"type": "directional", "direction": [0.3, -1, -0.4], "intensity": 0.25},
        ],
        "objects": [
            {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "material": "floor"},
            {"type": "mesh", "name": "trefoil knot", "smooth": True, "material": "knot",
             "vertices": verts, "indices": idx,
             "keyframes": [{"frame": 0, "rotate": [0, 0, 0]}, {"frame": 24, "rotate": [0, 60, 0]},
                           {"frame": 47, "rotate": [0, 120, 0]}]},
            {"type": "sphere", "center": [0, 0.25, 0], "radius": 0.25,
             "material": {"color": [0.2, 0.45, 0.9], "specular": 0.5, "shininess": 64},
             "interpolation": "smooth",
             "keyframes": [{"frame": 0, "translate": [1.6, 0, 0]}, {"frame": 16, "translate": [0, 0, 1.6]},
                           {"frame": 32, "translate": [-1.6, 0, 0]}, {"frame": 47, "translate": [0, 0, -1.6]}]},
        ],
    }


def plain_zeros(v):
    """v with every -0.0 written 0.0: the same scene, and text that survives
    the preview's formatter (JavaScript keeps -0 apart from 0)."""
    if isinstance(v, dict):
        return {k: plain_zeros(x) for k, x in v.items()}
    if isinstance(v, list):
        return [plain_zeros(x) for x in v]
    return 0.0 if isinstance(v, float) and v == 0 else v


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "scenes/animation.json"
    with open(out, "w") as f:
        f.write(json.dumps(plain_zeros(scene()), separators=(", ", ": ")) + "\n")


if __name__ == "__main__":
    main()
