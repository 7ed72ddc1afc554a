#!/usr/bin/env python3
"""mkspheres.py -- writes the 10x10-sphere Whitted benchmark scene twice:
bench/scenes/spheres10.json for rayd and bench/peers/spheres10.pov, the
same scene for POV-Ray 3.7.  Both files are checked in; rerun this after
changing either (python3 bench/mkspheres.py from the repository root).

100 spheres (radius 0.4, 1 apart) in a grid on a plane, every third one a
mirror, two point lights, max_depth 5, 1 sample, 1920x1080.

How the models line up (docs/scene-format.md, core/render/integrate.c):
  rayd ambient * color           POV  finish ambient (ambient_light 1)
  rayd diffuse * color * N.L     POV  finish diffuse (brilliance 1)
  rayd specular * (N.H)^shininess POV finish specular, roughness 1/shininess
                                      (POV's specular is Blinn's N.H too)
  rayd reflectivity              POV  finish reflection (added, not metallic)
  rayd point lights, no falloff  POV  light_source without fade
  rayd max_depth 5 bounces       POV  max_trace_level 6 (it counts the eye ray)
  rayd right-handed camera       POV  right -x*aspect (the right-handed form)
  linear colours, sRGB PNG       POV  assumed_gamma 1.0 (sRGB PNG by default)
"""
import json
import os

ROOT = os.path.dirname(os.path.abspath(__file__))

CAMERA = {"position": [0, 5.5, 9], "look_at": [0, 0, -0.8], "up": [0, 1, 0], "fov_x": 60}
BACKGROUND = [0.35, 0.55, 0.85]
LIGHTS = [{"type": "point", "position": [-6, 10, 8], "color": [1, 1, 1], "intensity": 0.7},
          {"type": "point", "position": [8, 12, -3], "color": [1, 0.95, 0.85], "intensity": 0.5}]
MATERIALS = {
    "floor":  {"color": [0.75, 0.75, 0.7], "ambient": 0.1, "diffuse": 0.8},
    "mirror": {"color": [0.9, 0.9, 0.9], "ambient": 0.05, "diffuse": 0.1, "specular": 0.8,
               "shininess": 200, "reflectivity": 0.8},
    "red":    {"color": [0.9, 0.15, 0.1], "ambient": 0.1, "diffuse": 0.8, "specular": 0.4,
               "shininess": 40},
    "green":  {"color": [0.15, 0.8, 0.2], "ambient": 0.1, "diffuse": 0.8, "specular": 0.4,
               "shininess": 40},
    "blue":   {"color": [0.15, 0.3, 0.9], "ambient": 0.1, "diffuse": 0.8, "specular": 0.4,
               "shininess": 40},
}
COLOURS = ["red", "green", "blue"]


def spheres():
    for j in range(10):
        for i in range(10):
            c = [i - 4.5, 0.4, j - 4.5 - 2]
            k = i + 10 * j
            yield c, 0.4, "mirror" if k % 3 == 0 else COLOURS[(k // 3 + j) % 3]


def write_json(path):
    objs = [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "material": "floor"}]
    objs += [{"type": "sphere", "center": c, "radius": r, "material": m} for c, r, m in spheres()]
    scene = {"camera": CAMERA,
             "render": {"width": 1920, "height": 1080, "samples": 1, "max_depth": 5,
                        "background": BACKGROUND, "seed": 0},
             "materials": MATERIALS, "lights": LIGHTS, "objects": objs}
    with open(path, "w") as f:
        f.write("{\n")
        for key in ("camera", "render", "materials", "lights"):
            f.write(' "%s": %s,\n' % (key, json.dumps(scene[key])))
        f.write(' "objects": [\n')
        f.write(",\n".join("  " + json.dumps(o) for o in objs))
        f.write("\n ]\n}\n")


def vec(v):
    return "<%s>" % ", ".join("%g" % x for x in v)


def finish(m):
    parts = ["ambient %g" % m.get("ambient", 0.1), "diffuse %g" % m.get("diffuse", 0.9)]
    if m.get("specular", 0) > 0:
        parts.append("specular %g roughness %g" % (m["specular"], 1.0 / m.get("shininess", 32)))
    if m.get("reflectivity", 0) > 0:
        parts.append("reflection { %g }" % m["reflectivity"])
    return " ".join(parts)


def write_pov(path):
    cam = CAMERA
    out = ["// spheres10.pov -- written by bench/mkspheres.py: the same scene as",
           "// bench/scenes/spheres10.json for POV-Ray 3.7 (see that script for the mapping).",
           "// povray +Ispheres10.pov +W1920 +H1080 -A +WT1 -D",
           "#version 3.7;",
           "global_settings { assumed_gamma 1.0 max_trace_level 6 ambient_light rgb 1 }",
           "background { rgb %s }" % vec(BACKGROUND),
           "camera { perspective location %s look_at %s sky %s" % (
               vec(cam["position"]), vec(cam["look_at"]), vec(cam["up"])),
           "         right -x*image_width/image_height up y angle %g }" % cam["fov_x"]]
    for l in LIGHTS:
        col = [c * l["intensity"] for c in l["color"]]
        out.append("light_source { %s color rgb %s }" % (vec(l["position"]), vec(col)))
    for name, m in MATERIALS.items():
        out.append("#declare M_%s = texture { pigment { rgb %s } finish { %s } }" % (
            name, vec(m["color"]), finish(m)))
    out.append("plane { y, 0 texture { M_floor } }")
    for c, r, m in spheres():
        out.append("sphere { %s, %g texture { M_%s } }" % (vec(c), r, m))
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


write_json(os.path.join(ROOT, "scenes", "spheres10.json"))
write_pov(os.path.join(ROOT, "peers", "spheres10.pov"))
