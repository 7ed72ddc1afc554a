# mitsuba_pt.py -- a rayd scene written as a Mitsuba 3 scene, for
# bench/pt.py (`make bench-pt`, where a Mitsuba 3 build is at hand).
#
#   python3 bench/peers/mitsuba_pt.py SCENE.json OUT.xml
#   mitsuba -m scalar_rgb -t THREADS -D spp=N -D seed=S -o OUT.exr OUT.xml
#
# The one description of each benchmark scene is rayd's JSON (pt.py writes
# it); this reads the subset pt.py uses and writes the same thing for
# Mitsuba, number for number, as cycles_pt.py does for Cycles:
#   camera    position, look_at, up +y and fov_x: Mitsuba's perspective
#             sensor with that look-at and fov_axis x (both y-up and
#             right-handed, so no change of coordinates)
#   objects   quads (Mitsuba's rectangle: [-1, 1]^2 at z = 0 carried onto
#             corner + s e1 + t e2, its normal along e1 x e2 as rayd's),
#             boxes (Mitsuba's cube, scaled to the size, moved to the
#             centre, then rayd's transform: rotate about +y, translate),
#             spheres (Mitsuba's analytic sphere) and PLY meshes with face
#             normals (as "smooth": false)
#   materials diffuse -> two-sided Lambert of colour x diffuse (rayd's
#             surfaces have no back face); transparency 1 -> smooth
#             dielectric of that ior, transmittance the colour; metallic
#             1 -> principled BSDF, metallic 1, that roughness (alpha =
#             roughness^2, F0 = colour, as rayd's GGX); emission -> an area
#             emitter of that radiance on a black surface, on both faces
#             as rayd's quads shine (a second, flipped emitter 1e-4 behind
#             the first: Mitsuba's area emitters light their front only)
#   render    max_depth + 1 -> path max_depth (Mitsuba counts the emitter
#             seen from the camera as depth 1), Russian roulette from
#             Mitsuba's default depth, box pixel filter of radius 1/2 (a
#             sample lands in its own pixel, as rayd's), linear float RGB
#             EXR, the sampler the scene's text names (default
#             multijitter: Mitsuba's stratified sampler)
#   world     black, or the environment file as Mitsuba's envmap at its
#             intensity, turned 180 degrees about +y: Mitsuba puts the
#             image's centre towards +z, rayd towards -z.  rayd (and Cycles
#             here) read a map's nearest texel, Mitsuba interpolates: a
#             Radiance .hdr is handed to it enlarged, each texel repeated
#             to a block of at least 1024 / width texels a side (a PFM
#             beside OUT.xml), so that its interpolation blends only the
#             blocks' edges (the studio map is 32 x 16: interpolated as
#             it is, the bunny scene came out 5.7% darker)
import json
import math
import os
import struct
import sys
from xml.sax.saxutils import quoteattr

SAMPLER = os.environ.get("MITSUBA_SAMPLER", "multijitter")


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def add(a, b):
    return [a[i] + b[i] for i in range(3)]


def scale(a, k):
    return [x * k for x in a]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    n = math.sqrt(sum(x * x for x in a))
    return scale(a, 1 / n)


def vec(v):
    return quoteattr("%r, %r, %r" % tuple(float(x) for x in v))


def matrix(m):
    """A 4x4 row-major matrix as Mitsuba's <matrix value=...>."""
    return '<transform name="to_world"><matrix value=%s/></transform>' % quoteattr(
        " ".join("%r" % float(x) for row in m for x in row))


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def columns(x, y, z, t):
    """The affine matrix taking the unit axes to x, y, z and 0 to t."""
    return [[x[0], y[0], z[0], t[0]], [x[1], y[1], z[1], t[1]], [x[2], y[2], z[2], t[2]],
            [0, 0, 0, 1]]


def bsdf(m):
    col = list(m.get("color", [1, 1, 1]))
    if m.get("transparency", 0) > 0:
        return ('<bsdf type="dielectric"><float name="int_ior" value="%r"/>'
                '<float name="ext_ior" value="1.0"/>'
                '<rgb name="specular_transmittance" value=%s/></bsdf>'
                % (float(m.get("ior", 1.5)), vec(col)))
    if m.get("metallic", 0) > 0:
        return ('<bsdf type="twosided"><bsdf type="principled"><rgb name="base_color" value=%s/>'
                '<float name="metallic" value="%r"/><float name="roughness" value="%r"/>'
                '</bsdf></bsdf>' % (vec(col), float(m["metallic"]), float(m.get("roughness", 0))))
    d = m.get("diffuse", 1)
    return ('<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value=%s/>'
            '</bsdf></bsdf>' % vec([c * d for c in col]))


def emitter(m):
    e = m.get("emission", [0, 0, 0])
    if max(e) <= 0:
        return ""
    return '<emitter type="area"><rgb name="radiance" value=%s/></emitter>' % vec(e)


def quad(o, m):
    c, e1, e2 = o["corner"], o["edge1"], o["edge2"]
    n = norm(cross(e1, e2))
    centre = add(c, scale(add(e1, e2), 0.5))
    out = []
    for side in ((1,) if not emitter(m) else (1, -1)):
        # the back emitter: flipped (x mirrored keeps the rectangle, turns
        # the normal) and 1e-4 behind, so each face's rays meet its own
        at = centre if side == 1 else add(centre, scale(n, -1e-4))
        x = scale(e1, 0.5 * side)
        out.append('<shape type="rectangle">%s%s%s</shape>'
                   % (matrix(columns(x, scale(e2, 0.5), n if side == 1 else scale(n, -1), at)),
                      bsdf(m), emitter(m)))
    return "\n".join(out)


def box(o, m):
    c, s = o["center"], o["size"]
    t = o.get("transform", {})
    ry = math.radians(t.get("rotate", [0, 0, 0])[1])
    tr = t.get("translate", [0, 0, 0])
    cs, sn = math.cos(ry), math.sin(ry)
    rot = [[cs, 0, sn, tr[0]], [0, 1, 0, tr[1]], [-sn, 0, cs, tr[2]], [0, 0, 0, 1]]
    place = columns([s[0] / 2, 0, 0], [0, s[1] / 2, 0], [0, 0, s[2] / 2], c)
    return '<shape type="cube">%s%s</shape>' % (matrix(mat_mul(rot, place)), bsdf(m))


def sphere(o, m):
    return ('<shape type="sphere"><point name="center" value=%s/><float name="radius" value="%r"/>'
            '%s%s</shape>' % (vec(o["center"]), float(o["radius"]), bsdf(m), emitter(m)))


def ply(o, m, scene_dir):
    path = os.path.join(scene_dir, o["source"]["file"])
    return ('<shape type="ply"><string name="filename" value=%s/>'
            '<boolean name="face_normals" value="true"/>%s</shape>' % (quoteattr(path), bsdf(m)))


def camera(cam, rs):
    return ('<sensor type="perspective"><float name="fov" value="%r"/>'
            '<string name="fov_axis" value="x"/><float name="near_clip" value="0.0001"/>'
            '<transform name="to_world"><lookat origin=%s target=%s up=%s/></transform>'
            '<sampler type="%s"><integer name="sample_count" value="$spp"/>'
            '<integer name="seed" value="$seed"/></sampler>'
            '<film type="hdrfilm"><integer name="width" value="%d"/>'
            '<integer name="height" value="%d"/><rfilter type="box"/>'
            '<string name="pixel_format" value="rgb"/>'
            '<string name="component_format" value="float32"/></film></sensor>'
            % (float(cam["fov_x"]), vec(cam["position"]), vec(cam["look_at"]),
               vec(cam.get("up", [0, 1, 0])), SAMPLER, rs["width"], rs["height"]))


def rgbe_scanline(data, at, w):
    """One scanline of a Radiance file from data[at:]: its w RGBE quads
    and where the next one starts (run-length coded or flat)."""
    if w < 8 or w > 32767 or data[at:at + 2] != b"\x02\x02" or data[at + 2] & 0x80:
        return [tuple(data[at + 4 * i:at + 4 * i + 4]) for i in range(w)], at + 4 * w
    at += 4
    chans = []
    for _ in range(4):
        out = []
        while len(out) < w:
            n = data[at]
            if n > 128:
                out += [data[at + 1]] * (n - 128)
                at += 2
            else:
                out += list(data[at + 1:at + 1 + n])
                at += 1 + n
        chans.append(out)
    return list(zip(*chans)), at


def read_hdr(path):
    """A Radiance .hdr (-Y h +X w) as rows of (r, g, b), top row first,
    each texel as stb_image (rayd's reader) turns it into floats."""
    with open(path, "rb") as f:
        data = f.read()
    at = data.index(b"\n\n") + 2
    end = data.index(b"\n", at)
    dims = data[at:end].split()
    if dims[0] != b"-Y" or dims[2] != b"+X":
        raise SystemExit("mitsuba_pt: %s: only -Y h +X w maps" % path)
    h, w = int(dims[1]), int(dims[3])
    at, rows = end + 1, []
    for _ in range(h):
        quads, at = rgbe_scanline(data, at, w)
        rows.append([(0.0, 0.0, 0.0) if e == 0 else
                     tuple(c * math.ldexp(1.0, e - 136) for c in (r, g, b))
                     for r, g, b, e in quads])
    return w, h, rows


def enlarged_pfm(path, out):
    """path's map with every texel repeated to a k x k block, as a PFM."""
    w, h, rows = read_hdr(path)
    k = max(1, -(-1024 // w))
    with open(out, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (w * k, h * k))
        for row in reversed(rows):  # PFM: bottom row first
            line = b"".join(struct.pack("<3f", *px) * k for px in row)
            f.write(line * k)
    return out


def world(rs, scene_dir, out):
    env = rs.get("environment")
    if env:
        path = os.path.join(scene_dir, env["file"])
        if path.lower().endswith(".hdr"):
            path = enlarged_pfm(path, os.path.splitext(out)[0] + ".env.pfm")
        return ('<emitter type="envmap"><string name="filename" value=%s/>'
                '<float name="scale" value="%r"/>'
                '<transform name="to_world"><rotate y="1" angle="180"/></transform></emitter>'
                % (quoteattr(path), float(env.get("intensity", 1))))
    bg = rs.get("background", [0, 0, 0])
    if max(bg) > 0:
        return '<emitter type="constant"><rgb name="radiance" value=%s/></emitter>' % vec(bg)
    return ""


def main():
    path, out = sys.argv[1], sys.argv[2]
    with open(path) as f:
        s = json.load(f)
    scene_dir = os.path.dirname(os.path.abspath(path))
    rs = s["render"]
    mats = s.get("materials", {})
    parts = ['<scene version="3.0.0">', '<default name="spp" value="16"/>',
             '<default name="seed" value="0"/>',
             '<integrator type="path"><integer name="max_depth" value="%d"/></integrator>'
             % (rs.get("max_depth", 5) + 1),
             camera(s["camera"], rs), world(rs, scene_dir, out)]
    for o in s["objects"]:
        m = o["material"]
        m = mats[m] if isinstance(m, str) else m
        if o["type"] == "quad":
            parts.append(quad(o, m))
        elif o["type"] == "box":
            parts.append(box(o, m))
        elif o["type"] == "sphere":
            parts.append(sphere(o, m))
        elif o["type"] == "mesh":
            parts.append(ply(o, m, scene_dir))
        else:
            raise SystemExit("mitsuba_pt: object type %s not supported" % o["type"])
    parts.append("</scene>")
    with open(out, "w") as f:
        f.write("\n".join(p for p in parts if p) + "\n")


main()
