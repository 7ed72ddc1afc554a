"""memory_helpers.py -- the memory budget's tests and bench build their
scenes and their slow clients here (tests/integration/memory_budget.sh,
tests/tools/memory_table.sh).

  texture_scene OUT SIDE TEXTURES TAG   a scene of TEXTURES spheres, each with
                                        its own SIDE x SIDE PNG texture
                                        (decoded: SIDE^2 texels each)
  gltf_zeros OUT COUNT                  a mesh whose glTF POSITION accessor has
                                        COUNT elements and no bufferView
  texture_mesh OUT SIDE COUNT DIR       one SIDE x SIDE texture and a mesh of
                                        COUNT vertices (DIR/bytes.glb, positions
                                        of 4 bytes each) in one scene: each under
                                        the budget's own limits, both together
                                        over it
  slow_bodies PORT N LEN DIR            N connections, each declaring a body of
                                        LEN bytes with Expect: 100-continue;
                                        those told to continue send all but
                                        16 bytes and hold; the others' status
                                        lines and Retry-After go to DIR/answers;
                                        DIR/sent is written when all are done;
                                        they hold until DIR/stop exists
  stalled_bodies PORT N LEN DIR         N connections, each declaring a body of
                                        LEN bytes and sending one byte of it;
                                        DIR/sent is written once all are, and
                                        they hold until DIR/stop exists
"""
import base64
import json
import os
import socket
import struct
import sys
import time
import zlib


def png(side, shade):
    """A SIDE x SIDE 8-bit RGB PNG of one colour (a few KB whatever SIDE)."""
    row = b"\x00" + bytes([shade, 255 - shade, 128]) * side
    raw = zlib.compress(row * side, 9)

    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", side, side, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", raw) + chunk(b"IEND", b"")


def texture_scene(out, side, n, tag):
    mats, objs = {}, []
    for i in range(n):
        b64 = base64.b64encode(png(side, (i * 37 + int(tag)) % 256)).decode()
        mats["t%d" % i] = {"color": [1, 1, 1], "diffuse": 0.8,
                           "texture": {"type": "image", "png_base64": b64}}
        objs.append({"type": "sphere", "center": [i - n / 2.0, 0, -5], "radius": 0.4,
                     "material": "t%d" % i})
    scene = {"camera": {"position": [0, 0, 3], "look_at": [0, 0, -5], "up": [0, 1, 0],
                        "fov_x": 60},
             "render": {"width": 32, "height": 32, "samples": 1, "max_depth": 1, "seed": int(tag)},
             "materials": mats, "lights": [{"type": "point", "position": [0, 5, 0],
                                            "color": [1, 1, 1]}],
             "objects": objs}
    open(out, "w").write(json.dumps(scene))


def zeros_mesh(count):
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
           "accessors": [{"componentType": 5126, "count": count, "type": "VEC3",
                          "min": [0, 0, 0], "max": [0, 0, 0]}]}
    return {"type": "mesh", "material": "m", "source": {"format": "gltf", "text": json.dumps(doc)}}


def gltf_zeros(out, count):
    scene = {"camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov_x": 60},
             "render": {"width": 8, "height": 8, "samples": 1},
             "materials": {"m": {"color": [1, 1, 1]}},
             "objects": [zeros_mesh(count)]}
    open(out, "w").write(json.dumps(scene))


def glb(doc, data):
    """A GLB of the glTF document doc and the BIN chunk data."""
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    data += b"\0" * (-len(data) % 4)
    body = (struct.pack("<I", len(text)) + b"JSON" + text +
            struct.pack("<I", len(data)) + b"BIN\0" + data)
    return b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body


def byte_mesh(count):
    """A GLB of count vertices stored as BYTE VEC3 at a 4-byte stride: a
    file a third the size of the floats it decodes to."""
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
           "buffers": [{"byteLength": count * 4}],
           "bufferViews": [{"buffer": 0, "byteLength": count * 4, "byteStride": 4}],
           "accessors": [{"bufferView": 0, "componentType": 5120, "count": count,
                          "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 0]}]}
    return glb(doc, bytes(count * 4))


def texture_mesh(out, side, count, folder):
    texture_scene(out, side, 1, 1)
    scene = json.load(open(out))
    scene["materials"]["m"] = {"color": [1, 1, 1]}
    open(os.path.join(folder, "bytes.glb"), "wb").write(byte_mesh(count))
    scene["objects"].append({"type": "mesh", "material": "m",
                             "source": {"format": "glb", "file": "bytes.glb"}})
    open(out, "w").write(json.dumps(scene))


def hold(held, folder):
    """DIR/sent says how many are held; they are closed once DIR/stop exists."""
    open(os.path.join(folder, "sent"), "w").write("%d held\n" % len(held))
    end = time.time() + 120  # only ends a hung case
    while not os.path.exists(os.path.join(folder, "stop")) and time.time() < end:
        time.sleep(0.05)
    for s in held:
        s.close()


def slow_bodies(port, n, length, folder):
    held, answers = [], []
    for i in range(n):
        s = socket.create_connection(("127.0.0.1", port), timeout=60)
        s.sendall(("POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                   "Content-Length: %d\r\nExpect: 100-continue\r\n\r\n" % length).encode())
        got = b""
        while b"\r\n\r\n" not in got:
            d = s.recv(4096)
            if not d:
                break
            got += d
        head = got.decode("latin-1")
        if head.startswith("HTTP/1.1 100"):
            s.sendall(b" " * (length - 16))  # all but the last bytes: the body stays unfinished
            held.append(s)
        else:
            retry = [l.split(":", 1)[1].strip() for l in head.split("\r\n")
                     if l.lower().startswith("retry-after:")]
            answers.append("%s retry=%s" % (head.split("\r\n")[0], retry[0] if retry else "-"))
            s.close()
    open(os.path.join(folder, "answers"), "w").write("\n".join(answers) + "\n")
    hold(held, folder)


def stalled_bodies(port, n, length, folder):
    held = []
    for i in range(n):
        s = socket.create_connection(("127.0.0.1", port), timeout=60)
        s.sendall(("POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                   "Content-Length: %d\r\n\r\n{" % length).encode())
        held.append(s)
    hold(held, folder)


if __name__ == "__main__":
    cmd = sys.argv[1]
    if cmd == "texture_scene":
        texture_scene(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
    elif cmd == "gltf_zeros":
        gltf_zeros(sys.argv[2], int(sys.argv[3]))
    elif cmd == "texture_mesh":
        texture_mesh(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
    elif cmd == "slow_bodies":
        slow_bodies(int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
    elif cmd == "stalled_bodies":
        stalled_bodies(int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
    else:
        sys.exit("unknown command " + cmd)
