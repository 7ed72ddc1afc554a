#!/usr/bin/env python3
"""png_strip.py -- joins PNG images side by side into one PNG.

    python3 tools/png_strip.py OUT.png IN1.png IN2.png ...

tools/readme_images.sh uses it for the README's turntable strip: the frames
rayd-render wrote, left to right in the order given.  Only the standard
library (zlib), so nothing is installed for it: it reads what rayd writes,
8-bit RGB or RGBA PNGs, not interlaced, undoing the five row filters, and
writes 8-bit RGB with filter 0 at zlib level 9.  Every input must have the
same height.
"""
import struct
import sys
import zlib


def chunks(data):
    pos = 8
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        yield kind, data[pos + 8:pos + 8 + n]
        pos += 12 + n


def paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    if pa <= pb and pa <= pc:
        return a
    return b if pb <= pc else c


def unfilter(kind, row, prev, bpp):
    out = bytearray(row)
    for i in range(len(out)):
        a = out[i - bpp] if i >= bpp else 0
        b = prev[i]
        c = prev[i - bpp] if i >= bpp else 0
        if kind == 1:
            out[i] = (out[i] + a) & 255
        elif kind == 2:
            out[i] = (out[i] + b) & 255
        elif kind == 3:
            out[i] = (out[i] + (a + b) // 2) & 255
        elif kind == 4:
            out[i] = (out[i] + paeth(a, b, c)) & 255
    return out


def read_rgb(path):
    """(width, height, rows of RGB bytes)."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit("png_strip: error: %s: not a PNG" % path)
    idat = b""
    for kind, body in chunks(data):
        if kind == b"IHDR":
            w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
    if depth != 8 or ctype not in (2, 6) or interlace:
        sys.exit("png_strip: error: %s: not an 8-bit RGB(A) PNG without interlace" % path)
    bpp = 3 if ctype == 2 else 4
    raw = zlib.decompress(idat)
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        start = y * (stride + 1)
        row = unfilter(raw[start], raw[start + 1:start + 1 + stride], prev, bpp)
        prev = row
        rows.append(row if bpp == 3 else bytes(b for i, b in enumerate(row) if i % 4 != 3))
    return w, h, rows


def write_rgb(path, w, h, rows):
    def chunk(kind, body):
        crc = zlib.crc32(kind + body) & 0xFFFFFFFF
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)

    raw = b"".join(b"\x00" + bytes(r) for r in rows)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def main(argv):
    if len(argv) < 3:
        sys.exit("usage: png_strip.py OUT.png IN.png...")
    images = [read_rgb(p) for p in argv[2:]]
    h = images[0][1]
    if any(im[1] != h for im in images):
        sys.exit("png_strip: error: the images differ in height")
    rows = [b"".join(bytes(im[2][y]) for im in images) for y in range(h)]
    write_rgb(argv[1], sum(im[0] for im in images), h, rows)


if __name__ == "__main__":
    main(sys.argv)
