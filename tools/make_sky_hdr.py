#!/usr/bin/env python3
"""make_sky_hdr.py -- writes scenes/sky.hdr, the example environment map.

    python3 tools/make_sky_hdr.py [OUT.hdr]     (default scenes/sky.hdr)
    python3 tools/make_sky_hdr.py --scene       and puts it, base64, into
                                                scenes/environment.json

A 64 x 32 equirectangular Radiance .hdr (rayd's layout: row 0 looks straight
up, the centre column looks down -Z): a sky that goes from deep blue at the
zenith to a pale haze at the horizon, a dim warm ground below it, and a sun
of about 4 texels, 40 degrees above the horizon toward -Z+X, bright enough
(radiance 60: about as much light as the whole sky) to cast shadows.
Everything is computed, no randomness, so the file's bytes never change; it
is small enough (8 KiB) to commit.  Flat RGBE scanlines: every reader of
the format takes them.  The example scene embeds the image (base64) rather
than naming the file, so that it renders everywhere a scene can: in the
server without --asset-dir and in the preview's examples menu.
"""
import base64
import json
import math
import sys

W, H = 64, 32
SUN_ELEVATION, SUN_AZIMUTH = 40.0, 35.0  # degrees; azimuth from -Z toward +X


def direction(i, j, w=W, h=H):
    """The direction of texel (i, j) of a w x h map, as rayd's lookup reads it."""
    theta = math.pi * (j + 0.5) / h
    phi = 2 * math.pi * ((i + 0.5) / w - 0.5)
    return (math.sin(theta) * math.sin(phi), math.cos(theta), -math.sin(theta) * math.cos(phi))


def sun_direction():
    e, a = math.radians(SUN_ELEVATION), math.radians(SUN_AZIMUTH)
    return (math.cos(e) * math.sin(a), math.sin(e), -math.cos(e) * math.cos(a))


def radiance(d):
    s = sun_direction()
    if sum(x * y for x, y in zip(d, s)) > math.cos(math.radians(6.5)):
        return (60.0, 56.0, 50.0)
    y = d[1]
    if y < 0:  # the ground: dim, warm, darker toward the nadir
        k = 0.25 + 0.15 * (1 + y)
        return (0.35 * k, 0.3 * k, 0.25 * k)
    t = y ** 0.5  # 0 at the horizon, 1 at the zenith
    horizon, zenith = (0.6, 0.65, 0.7), (0.08, 0.16, 0.45)
    return tuple(h + (z - h) * t for h, z in zip(horizon, zenith))


def rgbe(c):
    v = max(c)
    if v < 1e-32:
        return bytes(4)
    m, e = math.frexp(v)
    scale = m * 256.0 / v
    return bytes([int(c[0] * scale), int(c[1] * scale), int(c[2] * scale), e + 128])


def hdr_bytes(radiance_of, w=W, h=H):
    """A Radiance .hdr (flat RGBE) of radiance_of(direction) over a w x h map;
    tools/make_studio_hdr.py writes its map with it too."""
    data = bytearray(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w))
    for j in range(h):
        for i in range(w):
            data += rgbe(radiance_of(direction(i, j, w, h)))
    return bytes(data)


def embed(hdr, scene="scenes/environment.json"):
    with open(scene) as f:
        s = json.load(f)
    s["render"]["environment"]["base64"] = base64.b64encode(hdr).decode()
    with open(scene, "w") as f:
        f.write(json.dumps(s, indent=1) + "\n")


def main():
    args = [a for a in sys.argv[1:] if a != "--scene"]
    out = args[0] if args else "scenes/sky.hdr"
    data = hdr_bytes(radiance)
    with open(out, "wb") as f:
        f.write(data)
    if "--scene" in sys.argv[1:]:
        embed(data)


if __name__ == "__main__":
    main()
