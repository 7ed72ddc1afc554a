#!/usr/bin/env python3
"""make_gltf_scene.py -- writes scenes/gltf.json, the example of a whole-scene
glTF object.

    python3 tools/make_gltf_scene.py [OUT.json]     (default scenes/gltf.json)
    python3 tools/make_gltf_scene.py --glb OUT.glb  the .glb alone, to look at
                                                    it in another viewer

A small glTF 2.0 file built by hand: a tiled ground quad with a base colour
texture (a 32 x 32 PNG made here), a rough clay box, a polished gold
octahedron drawn twice (one node placed by translation/rotation/scale, the
other by a matrix, both under a parent node that turns them), a small
emissive gem, a KHR_lights_punctual spot light and a perspective camera.
The scene renders it with the file's own materials, light and camera
("camera" on the gltf object), so it shows what a gltf object reads.

The file is embedded as the base64 of a .glb, not as a .gltf's text: the
preview page embeds every scenes/*.json and its server refuses `file`
sources, and a base64 string (no quotes inside) stays one unbroken string
when the preview formats the scene.  Everything is computed, nothing random,
and the PNG's deflate stream is written as stored blocks by hand rather than
by zlib.compress, whose output may change with the zlib build: so the same
script always writes the same bytes (tests/integration/generated_files.sh
checks it).
"""
import base64
import json
import math
import struct
import sys
import zlib

# ---- the texture: a PNG of warm tiles with darker grout --------------------------------
TEX = 32


def texel(x, y):
    """Four tiles per image, each with a one-texel grout line and a soft
    shade, so the ground reads as tiles without looking noisy."""
    if x % 16 == 0 or y % 16 == 0:
        return (150, 138, 124)
    tile = (x // 16 + y // 16) % 2
    base = (205, 182, 150) if tile else (186, 160, 128)
    u, v = (x % 16) / 15.0, (y % 16) / 15.0
    k = 1.0 - 0.08 * (u + v) / 2  # a little darker toward one corner
    return tuple(int(c * k) for c in base)


def stored_zlib(raw):
    """A zlib stream of stored (uncompressed) deflate blocks: the same bytes
    whatever zlib does, unlike zlib.compress."""
    out = bytearray(b"\x78\x01")
    for i in range(0, max(len(raw), 1), 65535):
        block = raw[i:i + 65535]
        final = 1 if i + 65535 >= len(raw) else 0
        out += struct.pack("<BHH", final, len(block), len(block) ^ 0xFFFF) + block
    return bytes(out + struct.pack(">I", zlib.adler32(raw)))


def png(width, height, pixel):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    raw = bytearray()
    for y in range(height):
        raw.append(0)  # filter: none
        for x in range(width):
            raw += bytes(pixel(x, y))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", stored_zlib(bytes(raw))) + chunk(b"IEND", b""))


# ---- geometry: flat-shaded meshes as (positions, normals, uvs, indices) --------------------
def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def normalize(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def flat(triangles):
    """Unshared corners, one face normal each: the low-poly look (rayd keeps the
    file's NORMALs when every primitive has them)."""
    pos, nrm = [], []
    for a, b, c in triangles:
        n = normalize(cross(sub(b, a), sub(c, a)))
        pos += [a, b, c]
        nrm += [n, n, n]
    return pos, nrm, None, list(range(len(pos)))


def octahedron(r, h):
    ring = [[r, 0, 0], [0, 0, -r], [-r, 0, 0], [0, 0, r]]
    top, bottom = [0, h, 0], [0, -h, 0]
    tris = []
    for i in range(4):
        a, b = ring[i], ring[(i + 1) % 4]
        tris += [(top, a, b), (bottom, b, a)]
    return flat(tris)


def box(sx, sy, sz):
    c = [[x * sx, y * sy, z * sz] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = []
    for a, b, cc, d in faces:
        tris += [(c[a], c[b], c[cc]), (c[a], c[cc], c[d])]
    return flat(tris)


def gem(r):
    """A small round-cut stone: an 8-sided crown over a pointed pavilion."""
    n, tris = 8, []
    rim = [[r * math.cos(2 * math.pi * i / n), 0, r * math.sin(2 * math.pi * i / n)] for i in range(n)]
    table = [[0.55 * p[0], 0.45 * r, 0.55 * p[2]] for p in rim]
    tip, centre = [0, -1.1 * r, 0], [0, 0.45 * r, 0]
    for i in range(n):
        j = (i + 1) % n
        tris += [(rim[i], tip, rim[j]), (rim[i], rim[j], table[j]), (rim[i], table[j], table[i]),
                 (table[i], table[j], centre)]
    return flat(tris)


def ground(half, repeat):
    pos = [[-half, 0, -half], [-half, 0, half], [half, 0, half], [half, 0, -half]]
    uvs = [[0, 0], [0, repeat], [repeat, repeat], [repeat, 0]]
    return pos, [[0, 1, 0]] * 4, uvs, [0, 1, 2, 0, 2, 3]


# ---- transforms -------------------------------------------------------------------------------
def quat_axis_angle(axis, degrees):
    axis, h = normalize(axis), math.radians(degrees) / 2
    return [axis[0] * math.sin(h), axis[1] * math.sin(h), axis[2] * math.sin(h), math.cos(h)]


def look_at_matrix(eye, target, up=(0, 1, 0)):
    """A glTF node matrix (column-major) that puts a camera or a light at eye
    looking at target: glTF cameras and lights look down their -Z."""
    z = normalize(sub(eye, target))
    x = normalize(cross(list(up), z))
    y = cross(z, x)
    return [x[0], x[1], x[2], 0, y[0], y[1], y[2], 0, z[0], z[1], z[2], 0, eye[0], eye[1], eye[2], 1]


def look_rotation(eye, target):
    """The same orientation as a unit quaternion, for a TRS node."""
    m = look_at_matrix(eye, target)
    r = [[m[0], m[4], m[8]], [m[1], m[5], m[9]], [m[2], m[6], m[10]]]  # rows
    t = r[0][0] + r[1][1] + r[2][2]
    if t > 0:
        s = 2 * math.sqrt(1 + t)
        return [(r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s, s / 4]
    i = max(range(3), key=lambda k: r[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2 * math.sqrt(1 + r[i][i] - r[j][j] - r[k][k])
    q = [0.0, 0.0, 0.0, (r[k][j] - r[j][k]) / s]
    q[i], q[j], q[k] = s / 4, (r[j][i] + r[i][j]) / s, (r[k][i] + r[i][k]) / s
    return q


def turn_y(degrees, p):
    """p turned about +y (right-handed), as a glTF rotation would turn it."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return [c * p[0] + s * p[2], p[1], -s * p[0] + c * p[2]]


PAIR_TURN = 20  # degrees


def rounded(v):
    """Numbers as they go into the JSON: 6 decimals, so repr stays short and stable."""
    return [round(x, 6) + 0.0 for x in v]


# ---- the .glb -----------------------------------------------------------------------------
class Builder:
    def __init__(self):
        self.bin = bytearray()
        self.doc = {"bufferViews": [], "accessors": []}

    def view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            v["target"] = target
        self.bin += data
        self.doc["bufferViews"].append(v)
        return len(self.doc["bufferViews"]) - 1

    def floats(self, rows, kind, with_bounds=False):
        data = b"".join(struct.pack("<%df" % len(r), *r) for r in rows)
        a = {"bufferView": self.view(data, 34962), "componentType": 5126, "count": len(rows), "type": kind}
        if with_bounds:  # glTF wants min and max on POSITION
            f32 = [struct.unpack("<%df" % len(r), struct.pack("<%df" % len(r), *r)) for r in rows]
            a["min"] = [min(r[i] for r in f32) for i in range(len(rows[0]))]
            a["max"] = [max(r[i] for r in f32) for i in range(len(rows[0]))]
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1

    def indices(self, idx):
        data = struct.pack("<%dH" % len(idx), *idx)
        self.doc["accessors"].append({"bufferView": self.view(data, 34963), "componentType": 5123,
                                      "count": len(idx), "type": "SCALAR"})
        return len(self.doc["accessors"]) - 1

    def primitive(self, mesh, material):
        pos, nrm, uvs, idx = mesh
        attrs = {"POSITION": self.floats(pos, "VEC3", True), "NORMAL": self.floats(nrm, "VEC3")}
        if uvs:
            attrs["TEXCOORD_0"] = self.floats(uvs, "VEC2")
        return {"attributes": attrs, "indices": self.indices(idx), "material": material}


def build_glb():
    b = Builder()
    materials = [
        {"name": "Tiles", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0,
                                                   "roughnessFactor": 0.85}},
        {"name": "Clay", "pbrMetallicRoughness": {"baseColorFactor": [0.62, 0.2, 0.15, 1], "metallicFactor": 0,
                                                  "roughnessFactor": 0.9}},
        {"name": "Gold", "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.78, 0.34, 1], "metallicFactor": 1,
                                                  "roughnessFactor": 0.2}},
        {"name": "Glass", "pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.8, 1.0, 0.6], "metallicFactor": 0,
                                                  "roughnessFactor": 0.1},
         "alphaMode": "BLEND", "extensions": {"KHR_materials_ior": {"ior": 1.5}}},
    ]
    meshes = [
        {"name": "Ground", "primitives": [b.primitive(ground(3, 4), 0)]},
        {"name": "Box", "primitives": [b.primitive(box(0.45, 0.45, 0.45), 1)]},
        {"name": "Octahedron", "primitives": [b.primitive(octahedron(0.42, 0.6), 2)]},
        {"name": "Gem", "primitives": [b.primitive(gem(0.28), 3)]},
    ]
    image = b.view(png(TEX, TEX, texel))
    eye, target = [2.7, 2.2, 4.5], [0.3, 0.4, 0.0]
    light_at, light_target = [-2.5, 4.5, 2.5], [0.0, 0.3, 0.0]
    nodes = [
        {"name": "Ground", "mesh": 0},
        {"name": "Box", "mesh": 1, "translation": [-1.05, 0.45, -0.35], "rotation": rounded(quat_axis_angle([0, 1, 0], 28))},
        # the parent of both octahedra turns them together (their translations
        # below are where they end up in the world, turned back by PAIR_TURN)
        {"name": "Pair", "rotation": rounded(quat_axis_angle([0, 1, 0], -PAIR_TURN)), "children": [3, 4]},
        # the same mesh twice: once by TRS, once by a matrix (translate, then turn 45 degrees about y)
        {"name": "Octahedron TRS", "mesh": 2, "translation": rounded(turn_y(PAIR_TURN, [0.3, 0.6, -0.6])),
         "rotation": rounded(quat_axis_angle([0, 1, 0], 15))},
        {"name": "Octahedron matrix", "mesh": 2,
         "matrix": rounded([math.cos(math.pi / 4), 0, -math.sin(math.pi / 4), 0, 0, 1, 0, 0,
                            math.sin(math.pi / 4), 0, math.cos(math.pi / 4), 0] +
                           turn_y(PAIR_TURN, [1.9, 0.6, 0.2]) + [1])},
        {"name": "Gem", "mesh": 3, "translation": [-0.2, 0.31, 0.95], "scale": [1, 1, 1]},
        {"name": "Camera", "camera": 0, "matrix": rounded(look_at_matrix(eye, target))},
        {"name": "Key light", "translation": light_at, "rotation": rounded(look_rotation(light_at, light_target)),
         "extensions": {"KHR_lights_punctual": {"light": 0}}},
    ]
    doc = {
        "asset": {"version": "2.0", "generator": "rayd tools/make_gltf_scene.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_ior"],
        "scene": 0,
        "scenes": [{"name": "Display", "nodes": [0, 1, 2, 5, 6, 7]}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9729}],
        "images": [{"bufferView": image, "mimeType": "image/png"}],
        "cameras": [{"name": "Main", "type": "perspective",
                     "perspective": {"yfov": round(math.radians(38), 6), "aspectRatio": 1.5, "znear": 0.1}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "Key", "type": "spot", "color": [1.0, 0.93, 0.82], "intensity": 1.1,
             "spot": {"innerConeAngle": round(math.radians(25), 6), "outerConeAngle": round(math.radians(40), 6)}},
        ]}},
    }
    doc["bufferViews"], doc["accessors"] = b.doc["bufferViews"], b.doc["accessors"]
    while len(b.bin) % 4:
        b.bin.append(0)
    doc["buffers"] = [{"byteLength": len(b.bin)}]
    js = json.dumps(doc, separators=(",", ":"), sort_keys=True).encode()
    js += b" " * (-len(js) % 4)
    total = 12 + 8 + len(js) + 8 + len(b.bin)
    return (struct.pack("<III", 0x46546C67, 2, total) + struct.pack("<II", len(js), 0x4E4F534A) + js +
            struct.pack("<II", len(b.bin), 0x004E4942) + bytes(b.bin))


def scene_json(glb):
    scene = {
        "render": {"width": 240, "height": 160, "samples": 24, "max_depth": 4, "integrator": "path",
                   "environment": {"color": [0.21, 0.23, 0.28]}},
        "camera": {"aperture": 0},
        "objects": [
            {"type": "gltf", "name": "display", "camera": "Main",
             "source": {"format": "glb", "base64": base64.b64encode(glb).decode()}},
        ],
    }
    return json.dumps(scene, indent=1) + "\n"


def main():
    args = sys.argv[1:]
    glb = build_glb()
    if args[:1] == ["--glb"] and len(args) == 2:
        with open(args[1], "wb") as f:
            f.write(glb)
        return
    out = args[0] if args else "scenes/gltf.json"
    with open(out, "w") as f:
        f.write(scene_json(glb))


if __name__ == "__main__":
    main()
