#!/usr/bin/env python3
"""gltf_textures.py DIR SIZE... -- DIR/t.gltf, one textured triangle whose
materials have one solid-colour PNG base-colour texture each, SIZE x SIZE
pixels (data: URIs), and DIR/scene.json drawing it as a gltf object.  For
the per-file texel budget: a 4096 x 4096 image uses it all, so any image
after it must be refused."""
import base64, json, struct, sys, zlib


def png(w, h, rgb):
    row = b'\x00' + bytes(rgb) * w
    c = zlib.compressobj(9)
    z = b''.join(c.compress(row) for _ in range(h)) + c.flush()

    def chunk(t, d):
        return struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)

    ihdr = struct.pack('>IIBBBBB', w, h, 8, 2, 0, 0, 0)
    return b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', ihdr) + chunk(b'IDAT', z) + chunk(b'IEND', b'')


d, sizes = sys.argv[1], [int(a) for a in sys.argv[2:]]
buf = struct.pack('<9f', 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack('<6f', 0, 0, 1, 0, 0, 1)
uri = lambda mime, b: 'data:%s;base64,%s' % (mime, base64.b64encode(b).decode())
g = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
     "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "material": i}
                                for i in range(len(sizes))]}],
     "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": i}}}
                   for i in range(len(sizes))],
     "textures": [{"source": i} for i in range(len(sizes))],
     "images": [{"uri": uri("image/png", png(s, s, [200, 50, 50]))} for s in sizes],
     "buffers": [{"byteLength": len(buf), "uri": uri("application/octet-stream", buf)}],
     "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                     {"buffer": 0, "byteOffset": 36, "byteLength": 24}],
     "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                    "min": [0, 0, 0], "max": [1, 1, 0]},
                   {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}]}
open(d + '/t.gltf', 'w').write(json.dumps(g))
scene = {"render": {"width": 32, "height": 32},
         "camera": {"position": [0.3, 0.3, 3], "look_at": [0.3, 0.3, 0]},
         "lights": [{"type": "point", "position": [0, 0, 5]}],
         "objects": [{"type": "gltf", "source": {"file": "t.gltf"}}]}
open(d + '/scene.json', 'w').write(json.dumps(scene))
