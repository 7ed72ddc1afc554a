#!/usr/bin/env python3
"""make_scenes.py -- writes the bad-scene corpus: tests/bad/scenes/*.json and
tests/bad/scenes.tsv.

Run from anywhere:  python3 tests/bad/make_scenes.py
Edit the CASES table below, not the generated files, then run it again.

Every case is one small file with one thing wrong, and the exact line
rayd-render must print on stderr for it (exit status 1, no PNG written).

tsv columns: file, expected exit status, expected stderr line, and an
optional 4th column `bug`: the loader gets this case wrong today (it accepts
the file, or its message is wrong); the line says what it should print, so
the test fails until the loader is fixed.  Only on `bug` lines, a `*` in the
expected line matches any text: used where the right behaviour is sure (refuse
the file, name this position) but the exact wording is the fixer's choice.
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "scenes")

CASES = []  # (file, bytes, expected line, bug?)
# Every error line of the tools starts with the program's name (README: the
# command-line conventions); the cases below are written without it.
PREFIX = "rayd-render: "


def case(name, text, expected, bug=False):
    data = text.encode("utf-8") if isinstance(text, str) else text
    CASES.append((name, data, expected, bug))


def pos(data, off):
    """Line and column of byte offset off, as the loader counts them."""
    line, col = 1, 1
    for i, b in enumerate(data[:off]):
        # a line ends at LF, CR LF or a lone CR
        if b == 0x0A or (b == 0x0D and (i + 1 == off or data[i + 1] != 0x0A)):
            line, col = line + 1, 1
        elif b & 0xC0 != 0x80:
            col += 1
    return line, col


def at(text, needle, nth=0, delta=0):
    """'line L, column C' of the nth occurrence of needle in text."""
    data = text.encode("utf-8") if isinstance(text, str) else text
    needle = needle.encode("utf-8") if isinstance(needle, str) else needle
    off = -1
    for _ in range(nth + 1):
        off = data.index(needle, off + 1)
    return "line %d, column %d" % pos(data, off + delta)


def end(text):
    data = text.encode("utf-8") if isinstance(text, str) else text
    return "line %d, column %d" % pos(data, len(data))


E = "error: "

# ---- malformed JSON ---------------------------------------------------------
t = ""
case("empty.json", t, E + end(t) + ": malformed JSON: unexpected end of input")
t = "  \n \n"
case("whitespace-only.json", t, E + end(t) + ": malformed JSON: unexpected end of input")
t = '{"camera": {'
case("truncated-object.json", t, E + end(t) + ": malformed JSON: unexpected end of input")
t = '{"render": {"width": 64,\n'
case("truncated-after-comma.json", t, E + end(t) + ": malformed JSON: unexpected end of input")
t = '{"objects": [{"type": "sphere'
case("truncated-string.json", t, E + end(t) + ": malformed JSON: unterminated string")
t = '{"objects": [1 2]}'
case("missing-comma-array.json", t, E + at(t, "2") + ": malformed JSON: expected ',' or ']', found '2'")
t = '{"render": {"width": 64 "height": 48}}'
case("missing-comma-object.json", t,
     E + at(t, '"height"') + """: malformed JSON: expected ',' or '}', found '"'""")
# lone CRs (classic Mac OS line endings) end lines as LF and CR LF do
t = '{\r"render":\r {"width": 64 "height": 48}}'
case("missing-comma-lone-cr.json", t,
     E + "line 3, column 15: malformed JSON: expected ',' or '}', found '\"'")
t = '{\r\n"render":\r\n {"width": 64 "height": 48}}'
case("missing-comma-crlf.json", t,
     E + "line 3, column 15: malformed JSON: expected ',' or '}', found '\"'")
t = '{"render" {"width": 64}}'
case("missing-colon.json", t, E + at(t, " {", delta=1) + ": malformed JSON: expected ':' after the key, found '{'")
t = '{"render": {"width": 64,}}'
case("trailing-comma-object.json", t, E + at(t, ",}") + ": malformed JSON: trailing comma before '}' is not allowed")
t = '{"objects": [{"type": "sphere"},]}'
case("trailing-comma-array.json", t, E + at(t, ",]") + ": malformed JSON: trailing comma before ']' is not allowed")
t = '{render: {}}'
case("unquoted-key.json", t, E + at(t, "r") + ": malformed JSON: expected a string key in quotes, found 'r'")
t = "{'render': {}}"
case("single-quotes.json", t, E + at(t, "'") + ": malformed JSON: expected a string key in quotes, found '''")
t = '{\n  // a comment\n  "render": {}\n}'
case("comment.json", t, E + at(t, "/") + ": malformed JSON: expected a string key in quotes, found '/'")
t = '{"render": {}} x'
case("trailing-garbage.json", t, E + at(t, "x") + ": malformed JSON: unexpected data after the value, found 'x'")
t = '{}\n{}\n'
case("two-documents.json", t, E + at(t, "{", 1) + ": malformed JSON: unexpected data after the value, found '{'")
t = '{"render": {"width": NaN}}'
case("nan-literal.json", t, E + at(t, "N") + ": malformed JSON: expected a value, found 'N'")
t = '{"render": {"seed": Infinity}}'
case("infinity-literal.json", t, E + at(t, "I") + ": malformed JSON: expected a value, found 'I'")
t = '{"render": {"width": tru}}'
case("bad-literal.json", t, E + at(t, "tru") + ": malformed JSON: expected a value, found 't'")
t = '{"render": {"width": 0x40}}'
case("hex-number.json", t, E + at(t, "x") + ": malformed JSON: expected ',' or '}', found 'x'")
t = '{"render": {"width": 0640}}'
case("leading-zero.json", t, E + at(t, "6") + ": malformed JSON: invalid number (leading zeros are not allowed)")
t = '{"render": {"width": +640}}'
case("plus-sign.json", t, E + at(t, "+") + ": malformed JSON: expected a value, found '+'")
t = '{"render": {"width": 640.}}'
case("number-trailing-dot.json", t, E + at(t, "}") + ": malformed JSON: invalid number: digits must follow '.'")
t = '{"render": {"seed": 1e}}'
case("number-bad-exponent.json", t, E + at(t, "}") + ": malformed JSON: invalid number: digits must follow the exponent")
t = '{"objects": [{"type": "sph\\qere"}]}'
case("bad-escape.json", t, E + at(t, "\\") + ": malformed JSON: invalid escape in string")
t = '{"objects": [{"type": "\\u12G4"}]}'
case("bad-unicode-escape.json", t, E + at(t, "\\") + ": malformed JSON: \\u must be followed by 4 hex digits")
t = '{"objects": [{"type": "\\udc00"}]}'
case("lone-low-surrogate.json", t, E + at(t, "\\") + ": malformed JSON: lone low surrogate in \\u escape")
t = '{"objects": [{"type": "\\ud800x"}]}'
case("lone-high-surrogate.json", t,
     E + at(t, "\\") + ": malformed JSON: high surrogate in \\u escape without its low surrogate")
t = '{"objects": [{"type": "\\é"}]}'
case("escaped-non-ascii.json", t, E + at(t, "\\") + ": malformed JSON: invalid escape in string")
t = '{"materials": {"a\tb": {}}}'
case("raw-tab-in-string.json", t, E + at(t, "\t") + ": malformed JSON: control character in string (escape it)")
t = '{"materials": {"a\nb": {}}}'
case("raw-newline-in-string.json", t, E + at(t, "\n") + ": malformed JSON: control character in string (escape it)")
t = "[" * 65 + "]" * 65
case("deep-arrays.json", t, E + at(t, "[", 64) + ": malformed JSON: nesting deeper than 64 levels")
t = '{"objects": [' + '{"a": ' * 63 + "1" + "}" * 63 + "]}"
case("deep-objects.json", t, E + at(t, "{", 63) + ": malformed JSON: nesting deeper than 64 levels")
t = "[" * 200
case("deep-unclosed.json", t, E + at(t, "[", 64) + ": malformed JSON: nesting deeper than 64 levels")

# ---- bytes ------------------------------------------------------------------
def utf8case(name, bad, where=None):
    d = b'{"materials": {"' + bad + b'": {}}}'
    case(name, d, E + at(d, where or bad) + ": malformed JSON: invalid UTF-8")

utf8case("utf8-invalid-byte.json", b"\xff")
utf8case("utf8-overlong.json", b"\xc0\xaf")
utf8case("utf8-surrogate.json", b"\xed\xa0\x80")
utf8case("utf8-truncated-sequence.json", b"\xe2\x82")
utf8case("utf8-past-10ffff.json", b"\xf4\x90\x80\x80")
utf8case("utf8-lone-continuation.json", b"\x80")
utf8case("latin1-text.json", b"caf\xe9", b"\xe9")
d = b'{"render": {}}\x00'
case("nul-after-value.json", d, E + at(d, b"\x00") + ": malformed JSON: NUL byte after the value")
d = b'{"render": {"width": 64}}\n\xff'
case("invalid-byte-after-value.json", d, E + at(d, b"\xff") + ": malformed JSON: unexpected data after the value")
d = b'{\xef\xbb\xbf"render": {}}'
case("bom-inside.json", d, E + at(d, b"\xef") + ": malformed JSON: expected a string key in quotes")

d = b'{"objects": [{"type": "sph\\\x00ere"}]}\n'
case("nul-byte-after-backslash.json", d, E + at(d, b"\\") + ": malformed JSON: invalid escape in string")

# ---- the root -----------------------------------------------------------------
case("root-array.json", "[]\n", E + "the scene must be a JSON object, not an array")
case("root-string.json", '"scene"\n', E + "the scene must be a JSON object, not a string")
case("root-null.json", "null\n", E + "the scene must be a JSON object, not null")
case("root-number.json", "1\n", E + "the scene must be a JSON object, not a number")
ROOT_KEYS = "version, camera, render, materials, lights, groups, objects, animation"
case("root-unknown-key.json", '{"scene": {}}\n', E + "/scene: unknown key (allowed here: %s)" % ROOT_KEYS)
case("root-key-wrong-case.json", '{"Camera": {}}\n', E + "/Camera: unknown key (allowed here: %s)" % ROOT_KEYS)
case("root-empty-key.json", '{"": 1}\n', E + "/: unknown key (allowed here: %s)" % ROOT_KEYS)
case("root-key-slash.json", '{"camera/fov_x": 60}\n',
     E + "/camera~1fov_x: unknown key (allowed here: %s)" % ROOT_KEYS)
case("root-duplicate-key.json", '{"render": {"width": 64}, "render": {"width": 32}}\n',
     E + "/render: duplicate key")
case("root-duplicate-key-escaped.json", '{"render": {}, "rend\\u0065r": {}}\n', E + "/render: duplicate key")
case("materials-null.json", '{"materials": null}\n', E + "/materials: must be an object, not null")
case("lights-null.json", '{"lights": null}\n', E + "/lights: must be an array, not null")
case("objects-string.json", '{"objects": "sphere"}\n', E + "/objects: must be an array, not a string")
case("camera-array.json", '{"camera": [0, 1, 6]}\n', E + "/camera: must be an object, not an array")
case("version-2.json", '{"version": 2}\n', E + "/version: must be 1")
case("version-0.json", '{"version": 0}\n', E + "/version: must be 1")
case("version-string.json", '{"version": "1"}\n', E + "/version: must be an integer, not a string")
case("version-fraction.json", '{"version": 1.5}\n', E + "/version: must be an integer")

# ---- render -------------------------------------------------------------------
RENDER_KEYS = ("width, height, samples, max_depth, background, seed, integrator, environment, aov, "
               "denoise, clamp_indirect, filter_glossy")
case("render-array.json", '{"render": [640, 480]}\n', E + "/render: must be an object, not an array")
case("render-null.json", '{"render": null}\n', E + "/render: must be an object, not null")
case("render-unknown-key.json", '{"render": {"size": [640, 480]}}\n',
     E + "/render/size: unknown key (allowed here: %s)" % RENDER_KEYS)
case("aov-string.json", '{"render": {"aov": "albedo"}}\n',
     E + "/render/aov: must be an array of AOV names, not a string")
case("aov-number-item.json", '{"render": {"aov": ["albedo", 7]}}\n',
     E + "/render/aov/1: must be an AOV name, not a number")
case("aov-unknown.json", '{"render": {"aov": ["depth", "zdepth"]}}\n',
     E + "/render/aov/1: is no AOV; the AOVs are albedo, normal, depth, alpha, object, material, id and all")
case("aov-repeated.json", '{"render": {"aov": ["albedo", "depth", "albedo"]}}\n',
     E + "/render/aov/2: names \"albedo\" again (element 0 named it)")
case("aov-within-all.json", '{"render": {"aov": ["depth", "all"]}}\n',
     E + "/render/aov/1: names an AOV that element 0 (\"depth\") named already")
case("aov-list-in-string.json", '{"render": {"aov": ["albedo,normal"]}}\n',
     E + "/render/aov/0: is no AOV; the AOVs are albedo, normal, depth, alpha, object, material, id and all")
case("render-duplicate-key.json", '{"render": {"width": 64, "width": 32}}\n', E + "/render/width: duplicate key")
case("width-zero.json", '{"render": {"width": 0}}\n', E + "/render/width: must be >= 1")
case("width-negative.json", '{"render": {"width": -640}}\n', E + "/render/width: must be >= 1")
case("width-fraction.json", '{"render": {"width": 640.5}}\n', E + "/render/width: must be an integer")
case("width-string.json", '{"render": {"width": "640"}}\n', E + "/render/width: must be an integer, not a string")
case("width-bool.json", '{"render": {"width": true}}\n', E + "/render/width: must be an integer, not a boolean")
case("width-null.json", '{"render": {"width": null}}\n', E + "/render/width: must be an integer, not null")
case("width-over-limit.json", '{"render": {"width": 16385, "height": 1}}\n',
     E + "/render/width: must be <= 16384 (the limit)")
case("width-huge.json", '{"render": {"width": 1e300}}\n', E + "/render/width: must be <= 16384 (the limit)")
case("width-non-finite.json", '{"render": {"width": 1e999}}\n', E + "/render/width: must be a finite number")
case("height-zero.json", '{"render": {"height": 0}}\n', E + "/render/height: must be >= 1")
case("height-over-limit.json", '{"render": {"width": 1, "height": 16385}}\n',
     E + "/render/height: must be <= 16384 (the limit)")
case("too-many-pixels.json", '{"render": {"width": 16384, "height": 16384}}\n',
     E + "/render: width x height = 268435456 pixels is over the limit of 40000000 pixels")
case("too-many-pixels-just.json", '{"render": {"width": 8000, "height": 5001}}\n',
     E + "/render: width x height = 40008000 pixels is over the limit of 40000000 pixels")
case("samples-zero.json", '{"render": {"samples": 0}}\n', E + "/render/samples: must be >= 1")
case("samples-over-limit.json", '{"render": {"samples": 1025}}\n',
     E + "/render/samples: must be <= 1024 (the limit); --max-samples raises it (up to 65536)")
case("samples-fraction.json", '{"render": {"samples": 2.5}}\n', E + "/render/samples: must be an integer")
case("max-depth-negative.json", '{"render": {"max_depth": -1}}\n', E + "/render/max_depth: must be >= 0")
case("max-depth-over-limit.json", '{"render": {"max_depth": 33}}\n',
     E + "/render/max_depth: must be <= 32 (the limit)")
case("seed-negative.json", '{"render": {"seed": -1}}\n', E + "/render/seed: must be >= 0")
case("seed-fraction.json", '{"render": {"seed": 0.5}}\n', E + "/render/seed: must be an integer")
case("seed-over-2-53.json", '{"render": {"seed": 9007199254740992}}\n',
     E + "/render/seed: must be <= 9007199254740991")
case("seed-string.json", '{"render": {"seed": "42"}}\n', E + "/render/seed: must be an integer, not a string")
case("background-string.json", '{"render": {"background": "black"}}\n',
     E + "/render/background: must be an array of 3 numbers")
case("background-two-numbers.json", '{"render": {"background": [0, 0]}}\n',
     E + "/render/background: must be an array of 3 numbers")
case("background-four-numbers.json", '{"render": {"background": [0, 0, 0, 1]}}\n',
     E + "/render/background: must be an array of 3 numbers")
case("background-negative.json", '{"render": {"background": [0, -0.1, 0]}}\n',
     E + "/render/background/1: must be >= 0")
case("background-string-element.json", '{"render": {"background": [0, "0", 0]}}\n',
     E + "/render/background/1: must be a number, not a string")
case("background-non-finite.json", '{"render": {"background": [0, 0, 1e999]}}\n',
     E + "/render/background/2: must be a finite number")
case("background-huge.json", '{"render": {"background": [2e9, 0, 0]}}\n',
     E + "/render/background/0: must be in [-1e9, 1e9]")

# ---- camera -------------------------------------------------------------------
CAMERA_KEYS = "position, look_at, up, fov_x, fov_y, projection, view_width, aperture, focus_distance, frame, view, azimuth, elevation"
case("camera-string.json", '{"camera": "front"}\n', E + "/camera: must be an object, not a string")
case("camera-unknown-key.json", '{"camera": {"fov": 60}}\n',
     E + "/camera/fov: unknown key (allowed here: %s)" % CAMERA_KEYS)
case("camera-unknown-key-tilde.json", '{"camera": {"~fov": 60}}\n',
     E + "/camera/~0fov: unknown key (allowed here: %s)" % CAMERA_KEYS)
case("camera-duplicate-key.json", '{"camera": {"fov_x": 60, "fov_x": 50}}\n', E + "/camera/fov_x: duplicate key")
case("position-two-numbers.json", '{"camera": {"position": [0, 1]}}\n',
     E + "/camera/position: must be an array of 3 numbers")
case("position-nested-array.json", '{"camera": {"position": [[0], 1, 2]}}\n',
     E + "/camera/position/0: must be a number, not an array")
case("position-non-finite.json", '{"camera": {"position": [0, -1e999, 6]}}\n',
     E + "/camera/position/1: must be a finite number")
case("position-huge.json", '{"camera": {"position": [0, 0, 1e10]}}\n',
     E + "/camera/position/2: must be in [-1e9, 1e9]")
case("look-at-equals-position.json", '{"camera": {"position": [0, 1, 6], "look_at": [0, 1, 6]}}\n',
     E + "/camera/look_at: must differ from /camera/position")
case("look-at-default-equals-position.json", '{"camera": {"position": [0, 0, -1]}}\n',
     E + "/camera/look_at: must differ from /camera/position")
case("up-zero.json", '{"camera": {"up": [0, 0, 0]}}\n', E + "/camera/up: must not be a zero-length vector")
case("up-parallel.json", '{"camera": {"position": [0, 0, 0], "look_at": [0, 5, 0], "up": [0, 1, 0]}}\n',
     E + "/camera/up: must not be parallel to the view direction (look_at - position)")
case("up-antiparallel.json", '{"camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 0, 3]}}\n',
     E + "/camera/up: must not be parallel to the view direction (look_at - position)")
case("fov-x-zero.json", '{"camera": {"fov_x": 0}}\n', E + "/camera/fov_x: must be > 0")
case("fov-x-negative.json", '{"camera": {"fov_x": -60}}\n', E + "/camera/fov_x: must be > 0")
case("fov-x-180.json", '{"camera": {"fov_x": 180}}\n', E + "/camera/fov_x: must be <= 179")
case("fov-y-string.json", '{"camera": {"fov_y": "45"}}\n', E + "/camera/fov_y: must be a number, not a string")
case("fov-y-non-finite.json", '{"camera": {"fov_y": 1e999}}\n', E + "/camera/fov_y: must be a finite number")

# ---- materials ----------------------------------------------------------------
MAT_KEYS = ("color, ambient, diffuse, specular, shininess, reflectivity, transparency, ior, emission, "
            "roughness, metallic, texture, emission_sides")
case("materials-array.json", '{"materials": [{"color": [1, 0, 0]}]}\n',
     E + "/materials: must be an object, not an array")
case("material-not-object.json", '{"materials": {"red": [0.9, 0.1, 0.1]}}\n',
     E + "/materials/red: must be an object, not an array")
case("material-empty-name.json", '{"materials": {"": {"color": [1, 0, 0]}}}\n',
     E + "/materials/: a material name may not be empty")
case("material-duplicate-name.json", '{"materials": {"red": {}, "blue": {}, "red": {}}}\n',
     E + "/materials/red: duplicate key")
case("material-unknown-key.json", '{"materials": {"red": {"glossiness": 0.5}}}\n',
     E + "/materials/red/glossiness: unknown key (allowed here: %s)" % MAT_KEYS)
# A name longer than a message shows: cut, with the pointer going on after
# it (a 300-character name once overran the pointer's buffer and crashed).
case("material-name-long.json", '{"materials": {"' + "m" * 300 + '": {"color": [1, 2, "x"]}}}\n',
     E + "/materials/" + "m" * 64 + ".../color/2: must be a number, not a string")
case("material-name-long-slashes.json", '{"materials": {"' + "a/" * 150 + '": {"color": [1, 2, "x"]}}}\n',
     E + "/materials/" + "a~1" * 21 + "a.../color/2: must be a number, not a string")
case("material-name-escaped.json", '{"materials": {"a/b~c": {"colour": [1, 0, 0]}}}\n',
     E + "/materials/a~1b~0c/colour: unknown key (allowed here: %s)" % MAT_KEYS)
case("material-duplicate-key.json", '{"materials": {"red": {"diffuse": 0.5, "diffuse": 0.6}}}\n',
     E + "/materials/red/diffuse: duplicate key")
case("color-negative.json", '{"materials": {"m": {"color": [1, -0.5, 0]}}}\n',
     E + "/materials/m/color/1: must be >= 0")
case("color-two-numbers.json", '{"materials": {"m": {"color": [1, 0]}}}\n',
     E + "/materials/m/color: must be an array of 3 numbers")
case("color-hex-string.json", '{"materials": {"m": {"color": "#ff0000"}}}\n',
     E + "/materials/m/color: must be an array of 3 numbers")
case("emission-negative.json", '{"materials": {"m": {"emission": [-1, 0, 0]}}}\n',
     E + "/materials/m/emission/0: must be >= 0")
case("ambient-over-1.json", '{"materials": {"m": {"ambient": 1.5}}}\n', E + "/materials/m/ambient: must be <= 1")
case("diffuse-negative.json", '{"materials": {"m": {"diffuse": -0.1}}}\n', E + "/materials/m/diffuse: must be >= 0")
case("specular-over-1.json", '{"materials": {"m": {"specular": 2}}}\n', E + "/materials/m/specular: must be <= 1")
case("shininess-negative.json", '{"materials": {"m": {"shininess": -1}}}\n',
     E + "/materials/m/shininess: must be >= 0")
case("shininess-over-limit.json", '{"materials": {"m": {"shininess": 10001}}}\n',
     E + "/materials/m/shininess: must be <= 10000")
case("reflectivity-over-1.json", '{"materials": {"m": {"reflectivity": 1.01}}}\n',
     E + "/materials/m/reflectivity: must be <= 1")
case("transparency-negative.json", '{"materials": {"m": {"transparency": -0.5}}}\n',
     E + "/materials/m/transparency: must be >= 0")
case("transparency-bool.json", '{"materials": {"m": {"transparency": true}}}\n',
     E + "/materials/m/transparency: must be a number, not a boolean")
case("ior-zero.json", '{"materials": {"m": {"ior": 0}}}\n', E + "/materials/m/ior: must be > 0")
case("ior-over-10.json", '{"materials": {"m": {"ior": 11}}}\n', E + "/materials/m/ior: must be <= 10")
case("ior-non-finite.json", '{"materials": {"m": {"ior": -1e999}}}\n', E + "/materials/m/ior: must be a finite number")

# ---- lights ---------------------------------------------------------------------
case("lights-object.json", '{"lights": {"type": "point"}}\n', E + "/lights: must be an array, not an object")
case("light-not-object.json", '{"lights": [{"type": "point"}, "sun"]}\n',
     E + "/lights/1: must be an object, not a string")
case("light-missing-type.json", '{"lights": [{"position": [0, 5, 0]}]}\n', E + "/lights/0/type: is required")
case("light-type-number.json", '{"lights": [{"type": 1}]}\n', E + "/lights/0/type: must be a string, not a number")
case("light-unknown-type.json", '{"lights": [{"type": "laser"}]}\n',
     E + '/lights/0/type: unknown type "laser" (supported: point, directional, spot, area)')
case("light-type-ambient.json", '{"lights": [{"type": "ambient"}]}\n',
     E + '/lights/0/type: unknown type "ambient" (supported: point, directional, spot, area)')
case("light-type-wrong-case.json", '{"lights": [{"type": "Point"}]}\n',
     E + '/lights/0/type: unknown type "Point" (supported: point, directional, spot, area)')
case("point-light-direction.json", '{"lights": [{"type": "point", "direction": [0, -1, 0]}]}\n',
     E + "/lights/0/direction: unknown key (allowed here: type, position, color, intensity)")
case("directional-light-position.json", '{"lights": [{"type": "directional", "position": [0, 5, 0]}]}\n',
     E + "/lights/0/position: unknown key (allowed here: type, direction, color, intensity)")
case("spot-light-unknown-key.json", '{"lights": [{"type": "spot", "cutoff": 20}]}\n',
     E + "/lights/0/cutoff: unknown key (allowed here: type, position, direction, color, intensity, angle, falloff)")
case("light-duplicate-key.json", '{"lights": [{"type": "point", "intensity": 1, "intensity": 2}]}\n',
     E + "/lights/0/intensity: duplicate key")
case("intensity-negative.json", '{"lights": [{"type": "point", "intensity": -1}]}\n',
     E + "/lights/0/intensity: must be >= 0")
case("intensity-over-limit.json", '{"lights": [{"type": "point", "intensity": 2e6}]}\n',
     E + "/lights/0/intensity: must be <= 1e+06")
case("light-color-negative.json", '{"lights": [{"type": "point", "color": [1, 1, -1]}]}\n',
     E + "/lights/0/color/2: must be >= 0")
case("light-position-string.json", '{"lights": [{"type": "point", "position": "above"}]}\n',
     E + "/lights/0/position: must be an array of 3 numbers")
case("directional-direction-zero.json", '{"lights": [{"type": "directional", "direction": [0, 0, 0]}]}\n',
     E + "/lights/0/direction: must not be a zero-length vector")
case("spot-direction-zero.json", '{"lights": [{"type": "point"}, {"type": "spot", "direction": [0, 0, 0]}]}\n',
     E + "/lights/1/direction: must not be a zero-length vector")
case("spot-angle-zero.json", '{"lights": [{"type": "spot", "angle": 0}]}\n', E + "/lights/0/angle: must be > 0")
case("spot-angle-over-90.json", '{"lights": [{"type": "spot", "angle": 120}]}\n',
     E + "/lights/0/angle: must be <= 90")
case("spot-falloff-negative.json", '{"lights": [{"type": "spot", "falloff": -1}]}\n',
     E + "/lights/0/falloff: must be >= 0")
case("spot-falloff-over-angle.json", '{"lights": [{"type": "spot", "angle": 20, "falloff": 25}]}\n',
     E + "/lights/0/falloff: must be <= 20")
case("lights-over-limit.json", '{"lights": [' + ",".join(['{"type":"point"}'] * 1025) + ']}\n',
     E + "/lights: has 1025 lights; the limit is 1024")

names = ["m%d" % i for i in range(10001)]
case("materials-over-limit.json", '{"materials": {' + ",".join('"%s":{}' % n for n in names) + '}}\n',
     E + "/materials: has 10001 materials; the limit is 10000")

# ---- objects ----------------------------------------------------------------------
SPHERE_KEYS = "type, name, material, transform, center, radius"
PLANE_KEYS = "type, name, material, transform, point, normal"
case("objects-object.json", '{"objects": {"type": "sphere"}}\n', E + "/objects: must be an array, not an object")
case("object-null.json", '{"objects": [{"type": "sphere"}, null]}\n', E + "/objects/1: must be an object, not null")
case("object-missing-type.json", '{"objects": [{"center": [0, 0, -5], "radius": 1}]}\n',
     E + "/objects/0/type: is required")
case("object-type-null.json", '{"objects": [{"type": null}]}\n', E + "/objects/0/type: must be a string, not null")
case("object-unknown-type.json", '{"objects": [{"type": "sphere"}, {"type": "cube"}]}\n',
     E + '/objects/1/type: unknown type "cube" (supported: sphere, plane, box, cylinder, cone, disc, torus, triangle, quad, quadric, mesh, csg, instance, gltf)')
case("object-type-empty.json", '{"objects": [{"type": ""}]}\n',
     E + '/objects/0/type: unknown type "" (supported: sphere, plane, box, cylinder, cone, disc, torus, triangle, quad, quadric, mesh, csg, instance, gltf)')
case("sphere-unknown-key.json", '{"objects": [{"type": "sphere", "normal": [0, 1, 0]}]}\n',
     E + "/objects/0/normal: unknown key (allowed here: %s)" % SPHERE_KEYS)
case("plane-unknown-key.json", '{"objects": [{"type": "plane", "radius": 1}]}\n',
     E + "/objects/0/radius: unknown key (allowed here: %s)" % PLANE_KEYS)
case("object-duplicate-type.json", '{"objects": [{"type": "sphere", "type": "plane"}]}\n',
     E + "/objects/0/type: duplicate key")
case("object-duplicate-key.json", '{"objects": [{"type": "sphere", "radius": 1, "radius": 2}]}\n',
     E + "/objects/0/radius: duplicate key")
case("radius-zero.json", '{"objects": [{"type": "sphere", "radius": 0}]}\n', E + "/objects/0/radius: must be > 0")
case("radius-negative.json", '{"objects": [{"type": "sphere"}, {"type": "sphere", "radius": -1}]}\n',
     E + "/objects/1/radius: must be > 0")
case("radius-string.json", '{"objects": [{"type": "sphere", "radius": "1"}]}\n',
     E + "/objects/0/radius: must be a number, not a string")
case("radius-non-finite.json", '{"objects": [{"type": "sphere", "radius": 1e999}]}\n',
     E + "/objects/0/radius: must be a finite number")
case("radius-huge.json", '{"objects": [{"type": "sphere", "radius": 2e9}]}\n',
     E + "/objects/0/radius: must be <= 1e+09")
case("center-four-numbers.json", '{"objects": [{"type": "sphere", "center": [0, 0, -5, 1]}]}\n',
     E + "/objects/0/center: must be an array of 3 numbers")
case("center-null-element.json", '{"objects": [{"type": "sphere", "center": [0, null, -5]}]}\n',
     E + "/objects/0/center/1: must be a number, not null")
case("plane-normal-zero.json", '{"objects": [{"type": "plane", "normal": [0, 0, 0]}]}\n',
     E + "/objects/0/normal: must not be a zero-length vector")
case("plane-normal-underflow.json", '{"objects": [{"type": "plane", "normal": [1e-200, 0, 0]}]}\n',
     E + "/objects/0/normal: must not be a zero-length vector")
case("plane-point-non-finite.json", '{"objects": [{"type": "plane", "point": [0, 1e999, 0]}]}\n',
     E + "/objects/0/point/1: must be a finite number")
case("object-name-number.json", '{"objects": [{"type": "sphere", "name": 7}]}\n',
     E + "/objects/0/name: must be a string, not a number")
case("material-unknown-name.json",
     '{"materials": {"red": {}}, "objects": [{"type": "sphere", "material": "green"}]}\n',
     E + '/objects/0/material: unknown material "green" (not a key of /materials)')
case("material-name-wrong-case.json",
     '{"materials": {"red": {}}, "objects": [{"type": "sphere", "material": "Red"}]}\n',
     E + '/objects/0/material: unknown material "Red" (not a key of /materials)')
case("material-ref-no-materials.json", '{"objects": [{"type": "sphere", "material": "red"}]}\n',
     E + '/objects/0/material: unknown material "red" (not a key of /materials)')
case("material-ref-empty.json", '{"materials": {"red": {}}, "objects": [{"type": "sphere", "material": ""}]}\n',
     E + '/objects/0/material: unknown material "" (not a key of /materials)')
case("material-ref-number.json", '{"objects": [{"type": "sphere", "material": 3}]}\n',
     E + "/objects/0/material: must be a material name or a material object, not a number")
case("material-inline-unknown-key.json", '{"objects": [{"type": "plane", "material": {"colour": [1, 1, 1]}}]}\n',
     E + "/objects/0/material/colour: unknown key (allowed here: %s)" % MAT_KEYS)
case("material-inline-bad-value.json",
     '{"objects": [{"type": "sphere"}, {"type": "sphere", "material": {"reflectivity": 2}}]}\n',
     E + "/objects/1/material/reflectivity: must be <= 1")

# ---- meshes ---------------------------------------------------------------------
MESH_KEYS = "type, name, material, transform, source, vertices, indices, normals, uvs, smooth"
TRI = '"vertices": [0, 0, 0, 1, 0, 0, 0, 1, 0]'


def mesh(extra):
    return '{"objects": [{"type": "mesh", %s}]}\n' % extra


case("mesh-vertices-missing.json", mesh('"indices": [0, 1, 2]'),
     E + "/objects/0/vertices: is required (x, y, z of each vertex, flat)")
case("mesh-vertices-object.json", mesh('"vertices": {}, "indices": [0, 1, 2]'),
     E + "/objects/0/vertices: must be an array of numbers, not an object")
case("mesh-vertices-not-triples.json", mesh('"vertices": [0, 0, 0, 1], "indices": [0, 1, 2]'),
     E + "/objects/0/vertices: must hold a multiple of 3 numbers (at least 3); it has 4")
case("mesh-indices-missing.json", mesh(TRI), E + "/objects/0/indices: is required (3 vertex indices per triangle)")
case("mesh-indices-empty.json", mesh(TRI + ', "indices": []'),
     E + "/objects/0/indices: must hold a multiple of 3 indices (at least 3); it has 0")
case("mesh-indices-not-triples.json", mesh(TRI + ', "indices": [0, 1, 2, 0]'),
     E + "/objects/0/indices: must hold a multiple of 3 indices (at least 3); it has 4")
case("mesh-index-out-of-range.json", mesh(TRI + ', "indices": [0, 1, 3]'),
     E + "/objects/0/indices/2: must be an integer in 0..2 (a vertex index)")
case("mesh-index-negative.json", mesh(TRI + ', "indices": [0, -1, 2]'),
     E + "/objects/0/indices/1: must be an integer in 0..2 (a vertex index)")
case("mesh-index-fraction.json", mesh(TRI + ', "indices": [0, 1, 1.5]'),
     E + "/objects/0/indices/2: must be an integer in 0..2 (a vertex index)")
case("mesh-normals-count.json", mesh(TRI + ', "indices": [0, 1, 2], "normals": [0, 0, 1]'),
     E + "/objects/0/normals: must have one entry per vertex (3)")
case("mesh-normal-zero.json", mesh(TRI + ', "indices": [0, 1, 2], "normals": [0, 0, 1, 0, 0, 0, 0, 0, 1]'),
     E + "/objects/0/normals/3: normal 1 must not be a zero-length vector")
case("mesh-uvs-count.json", mesh(TRI + ', "indices": [0, 1, 2], "uvs": [0, 0]'),
     E + "/objects/0/uvs: must have one entry per vertex (3)")
case("mesh-smooth-number.json", mesh(TRI + ', "indices": [0, 1, 2], "smooth": 1'),
     E + "/objects/0/smooth: must be true or false, not a number")
case("mesh-unknown-key.json", mesh(TRI + ', "indices": [0, 1, 2], "faces": []'),
     E + "/objects/0/faces: unknown key (allowed here: %s)" % MESH_KEYS)
case("mesh-sphere-key.json", mesh('"center": [0, 0, 0]'),
     E + "/objects/0/center: unknown key (allowed here: %s)" % MESH_KEYS)

# ---- mesh sources (OBJ / PLY text, base64 or a file) ---------------------------------
import json  # noqa: E402


def src(source, **extra):
    o = {"type": "mesh", "source": source}
    o.update(extra)
    return json.dumps({"objects": [o]}) + "\n"


OBJ = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
PLY_HEAD = ("ply\nformat ascii 1.0\nelement vertex %s\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n")
SP = "/objects/0/source"
case("mesh-source-string.json", src("cube.obj"), E + SP + ": must be an object, not a string")
case("mesh-source-unknown-key.json", src({"format": "obj", "text": OBJ, "unit": "m"}),
     E + SP + "/unit: unknown key (allowed here: format, text, base64, file)")
case("mesh-source-two-inputs.json", src({"format": "obj", "text": OBJ, "base64": "AA=="}),
     E + SP + ': needs exactly one of "text", "base64" or "file"')
case("mesh-source-no-input.json", src({"format": "obj"}), E + SP + ': needs exactly one of "text", "base64" or "file"')
case("mesh-source-no-format.json", src({"text": OBJ}), E + SP + '/format: is required ("obj", "ply", "gltf" or "glb")')
case("mesh-source-file-no-format.json", src({"file": "models/part.stl"}),
     E + SP + '/format: is required ("obj", "ply", "gltf" or "glb"): "models/part.stl" does not end in '
     ".obj, .ply, .gltf or .glb")
case("mesh-source-unknown-format.json", src({"format": "stl", "text": "solid x"}),
     E + SP + '/format: unknown value "stl" (supported: obj, ply, gltf, glb)')
case("mesh-source-format-uppercase.json", src({"format": "OBJ", "text": OBJ}),
     E + SP + '/format: unknown value "OBJ" (supported: obj, ply, gltf, glb)')
case("mesh-source-text-number.json", src({"format": "obj", "text": 5}), E + SP + "/text: must be a string, not a number")
case("mesh-source-with-vertices.json", src({"format": "obj", "text": OBJ}, vertices=[0, 0, 0]),
     E + '/objects/0/vertices: cannot be combined with "source"')
case("mesh-source-bad-base64.json", src({"format": "ply", "base64": "@@@@"}),
     E + SP + "/base64: base64: invalid character '@' at offset 0")
case("mesh-source-base64-padding.json", src({"format": "obj", "base64": "dg="}),
     E + SP + "/base64: base64: incomplete padding at offset 3 (expected 2 '=')")
case("mesh-source-missing-file.json", src({"format": "obj", "file": "no-such-mesh.obj"}),
     E + SP + '/file: cannot open "no-such-mesh.obj": No such file or directory')
case("mesh-source-obj-empty.json", src({"format": "obj", "text": ""}), E + SP + "/text: OBJ has no faces ('f' lines)")
case("mesh-source-obj-no-faces.json", src({"format": "obj", "text": "v 0 0 0\nv 1 0 0\n"}),
     E + SP + "/text: OBJ has no faces ('f' lines)")
case("mesh-source-obj-lone-cr.json", src({"format": "obj", "text": OBJ.replace("\n", "\r")}),
     E + SP + "/text: OBJ line 1: the lines end in a lone CR (classic Mac OS line endings); "
     "save the file with LF or CR LF line endings")
case("mesh-source-obj-short-vertex.json", src({"format": "obj", "text": "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"}),
     E + SP + "/text: OBJ line 1: 'v' needs 3 numbers, found 2")
case("mesh-source-obj-index-zero.json", src({"format": "obj", "text": OBJ.replace("f 1 2 3", "f 1 2 0")}),
     E + SP + "/text: OBJ line 4: face index 0 is invalid (OBJ counts from 1)")
case("mesh-source-obj-index-out-of-range.json", src({"format": "obj", "text": OBJ.replace("f 1 2 3", "f 1 2 4")}),
     E + SP + "/text: OBJ line 4: face index 4 is out of range (1..3)")
case("mesh-source-obj-two-corners.json", src({"format": "obj", "text": OBJ.replace("f 1 2 3", "f 1 2")}),
     E + SP + "/text: OBJ line 4: face has 2 vertices (at least 3 needed)")
case("mesh-source-obj-huge-number.json", src({"format": "obj", "text": OBJ.replace("v 0 0 0", "v 0 0 1e39")}),
     E + SP + "/text: OBJ line 1: number '1e39' in 'v' is not a finite float")
case("mesh-source-obj-nan.json", src({"format": "obj", "text": OBJ.replace("v 0 0 0", "v 0 0 nan")}),
     E + SP + "/text: OBJ line 1: number 'nan' in 'v' is not a finite float")
case("mesh-source-ply-not-ply.json", src({"format": "ply", "text": "not a ply"}),
     E + SP + "/text: PLY header line 1: not a PLY file (expected 'ply')")
case("mesh-source-ply-truncated-header.json", src({"format": "ply", "text": "ply\nformat ascii 1.0\n"}),
     E + SP + "/text: PLY header: no 'end_header' line (truncated header?)")
case("mesh-source-ply-huge-count.json", src({"format": "ply", "text": PLY_HEAD % "4000000000" + "0 0 0\n"}),
     E + SP + "/text: PLY header line 3: element 'vertex' claims 4000000000 records but the body has only 6 bytes")
case("mesh-source-ply-index-out-of-range.json",
     src({"format": "ply", "text": PLY_HEAD % "3" + "0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"}),
     E + SP + "/text: PLY face 0: vertex index 5 is out of range (0..2)")

# glTF: one triangle, its buffer a data: URI; each case breaks one thing.
GLTF_BIN = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="


def gltf(edit=None):
    d = {"asset": {"version": "2.0"},
         "buffers": [{"byteLength": 44, "uri": "data:application/octet-stream;base64," + GLTF_BIN}],
         "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
         "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"},
                       {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
         "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
         "nodes": [{"mesh": 0}]}
    if edit:
        edit(d)
    return src({"format": "gltf", "text": json.dumps(d)})


GP = SP + "/gltf"
case("mesh-source-gltf-count.json", gltf(lambda d: d["accessors"][0].update(count=100)),
     E + GP + "/accessors/0/count: exceeds the buffer view (offset 0 + 100 elements of stride 12 need 1200 bytes; bufferView 0 has 36)")
case("mesh-source-gltf-cycle.json", gltf(lambda d: d.update(scenes=[{"nodes": [0, 1]}], nodes=[{"mesh": 0}, {"children": [2]}, {"children": [1]}])),
     E + GP + "/nodes/2/children/0: node 1 is its own ancestor (the node hierarchy has a cycle)")
case("mesh-source-gltf-draco.json", gltf(lambda d: d.update(extensionsRequired=["KHR_draco_mesh_compression"])),
     E + GP + "/extensionsRequired/0: KHR_draco_mesh_compression: compressed meshes are not supported; export the file without compression")
case("mesh-source-gltf-index.json", gltf(lambda d: d["accessors"][1].update(componentType=5126)),
     E + GP + "/accessors/1/componentType: indices must be UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT (5121, 5123, 5125), not 5126")
case("mesh-source-gltf-syntax.json", src({"format": "gltf", "text": '{"asset": {"version": "2.0"},\n "nodes": [}'}),
     E + GP + ": glTF JSON line 2, column 12: malformed JSON: expected a value, found '}'")
def gltf_object(edit=None, **extra):
    """A "gltf" object (the file as a whole scene) of gltf()'s document."""
    s = json.loads(gltf(edit))
    s["objects"][0]["type"] = "gltf"
    s["objects"][0].update(extra)
    return json.dumps(s) + "\n"


case("gltf-object-base-color.json",
     gltf_object(lambda d: d.update(materials=[{"pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 2, 1]}}])),
     E + GP + "/materials/0/pbrMetallicRoughness/baseColorFactor: must be numbers in [0, 1]")
case("gltf-object-material-index.json",
     gltf_object(lambda d: d["meshes"][0]["primitives"][0].update(material=3)),
     E + GP + "/meshes/0/primitives/0/material: 3 is not an index into /materials (the file has 0)")
case("gltf-object-texture-index.json",
     gltf_object(lambda d: d.update(materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}}],
                                    textures=[{"source": 0}])),
     E + GP + "/materials/0/pbrMetallicRoughness/baseColorTexture/index: must be a texture index in 0..0")
case("gltf-object-no-textures.json",
     gltf_object(lambda d: d.update(materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}])),
     E + GP + "/materials/0/pbrMetallicRoughness/baseColorTexture/index: names a texture, but the file has no /textures")
case("gltf-object-texcoord.json",
     gltf_object(lambda d: d.update(materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 0.5}}}],
                                    textures=[{"source": 0}])),
     E + GP + "/materials/0/pbrMetallicRoughness/baseColorTexture/texCoord: must be an integer in 0..7 (TEXCOORD_0 to TEXCOORD_7)")
case("gltf-object-no-images.json",
     gltf_object(lambda d: d.update(materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
                                    textures=[{"source": 0}])),
     E + GP + "/textures/0/source: the file has no /images (images of other extensions are not read)")
case("gltf-object-light-index.json",
     gltf_object(lambda d: d["nodes"][0].update(extensions={"KHR_lights_punctual": {"light": 2}})),
     E + GP + "/nodes/0/extensions/KHR_lights_punctual/light: names a light, but the file has no /extensions/KHR_lights_punctual/lights")
case("gltf-object-camera-name.json", gltf_object(camera="front"),
     E + "/objects/0/camera: the glTF has no cameras named \"front\"")
case("gltf-object-camera-none.json", gltf_object(camera=0),
     E + "/objects/0/camera: the glTF has no cameras")
case("gltf-object-scene-index.json", gltf_object(lambda d: d.update(scenes=[{"nodes": [0]}]), scene=1),
     E + "/objects/0/scene: must be an index in 0..0 of the glTF's scenes")
case("gltf-object-camera-clash.json",
     json.dumps(dict(json.loads(gltf_object(lambda d: d.update(cameras=[{"type": "perspective", "perspective": {"yfov": 0.7}}], nodes=[{"mesh": 0}, {"camera": 0, "translation": [0, 0, 3]}], scenes=[{"nodes": [0, 1]}]), camera=0)), camera={"position": [0, 0, 5]})) + "\n",
     E + "/objects/0/camera: the glTF camera sets the scene's camera: /camera/position cannot be given too (only aperture and focus_distance can)")
case("gltf-object-in-group.json",
     json.dumps({"groups": {"g": [json.loads(gltf_object())["objects"][0]]}}) + "\n",
     E + "/groups/g/0/type: a gltf object cannot be inside a group or a CSG object (its meshes are a group of their own)")

case("mesh-source-glb-short.json", src({"format": "glb", "base64": "Z2xURgIAAAA="}),
     E + GP + ": GLB file ends early (8 bytes)")

# ---- transforms -------------------------------------------------------------------
def xf(t, kind="sphere"):
    return '{"objects": [{"type": "%s", "transform": %s}]}\n' % (kind, t)


case("transform-string.json", xf('"none"'), E + "/objects/0/transform: must be an object, not a string")
case("transform-unknown-key.json", xf('{"translate": [0, 0, 0], "shear": 1}'),
     E + "/objects/0/transform/shear: unknown key (allowed here: translate, rotate, scale, matrix)")
case("transform-step-not-object.json", xf('[{"scale": 2}, 5]'),
     E + "/objects/0/transform/1: must be an object, not a number")
case("transform-translate-huge.json", xf('{"translate": [0, 0, 2e9]}'),
     E + "/objects/0/transform/translate/2: must be in [-1e9, 1e9]")
case("transform-scale-zero-axis.json", xf('{"scale": [1, 0, 1]}', "plane"),
     E + "/objects/0/transform/scale: must not be zero (or smaller than 1e-9) in any axis")
case("transform-scale-over.json", xf('{"scale": -2e9}'), E + "/objects/0/transform/scale: must be >= -1e+09")
case("transform-rotate-axis-zero.json", xf('{"rotate": {"axis": [0, 0, 0], "angle": 5}}'),
     E + "/objects/0/transform/rotate/axis: must not be a zero-length vector")
case("transform-rotate-unknown-key.json", xf('{"rotate": {"axis": [0, 0, 1], "deg": 5}}'),
     E + "/objects/0/transform/rotate/deg: unknown key (allowed here: axis, angle)")
case("transform-rotate-angle-over.json", xf('{"rotate": {"angle": 2e6}}'),
     E + "/objects/0/transform/rotate/angle: must be <= 1e+06")
case("transform-matrix-15-numbers.json", xf('{"matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0]}'),
     E + "/objects/0/transform/matrix: must be an array of 16 numbers (a 4x4 matrix, row by row)")
case("transform-matrix-singular.json", xf('{"matrix": [1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}'),
     E + "/objects/0/transform/matrix: must be invertible with last row [0, 0, 0, 1]")
case("transform-matrix-projective.json", xf('{"matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 1]}'),
     E + "/objects/0/transform/matrix: must be invertible with last row [0, 0, 0, 1]")
case("transform-matrix-and-scale.json",
     xf('{"matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], "scale": 2}'),
     E + "/objects/0/transform/matrix: cannot be combined with translate, rotate or scale")


# ---- render.integrator, camera projection and lens, PBR, textures, area lights,
#      more shapes, CSG, groups and instances --------------------------------------
case('integrator-unknown.json', '{"render": {"integrator": "bidir"}}\n',
     'error: /render/integrator: unknown value "bidir" (supported: whitted, path)')
case('integrator-number.json', '{"render": {"integrator": 1}}\n',
     'error: /render/integrator: must be a string, not a number')
case('projection-unknown.json', '{"camera": {"projection": "fisheye"}}\n',
     'error: /camera/projection: unknown value "fisheye" (supported: perspective, orthographic)')
case('view-width-zero.json', '{"camera": {"projection": "orthographic", "view_width": 0}}\n',
     'error: /camera/view_width: must be > 0')
case('aperture-negative.json', '{"camera": {"aperture": -0.1}}\n',
     'error: /camera/aperture: must be >= 0')
case('focus-distance-zero.json', '{"camera": {"aperture": 0.1, "focus_distance": 0}}\n',
     'error: /camera/focus_distance: must be > 0')
case('frame-nothing-bounded.json', '{"camera": {"frame": "all"}, "objects": [{"type": "plane"}]}\n',
     'error: /camera/frame: the scene has no bounded object to frame (planes and quadrics have no bounds)')
case('frame-too-small.json',
     '{"camera": {"frame": "all"}, "objects": [{"type": "sphere", "center": [5, 0, 0], "radius": 1e-13}]}\n',
     'error: /camera/frame: the scene\'s bounds (a sphere of radius 1e-13 around [5, 0, 0]) are too '
     'small to frame so far from the origin; scale the scene up')
case('frame-with-position.json',
     '{"camera": {"frame": "all", "position": [0, 0, 5]}, "objects": [{"type": "sphere"}]}\n',
     'error: /camera/position: must not be given with /camera/frame (the view sets it)')
case('view-without-frame.json', '{"camera": {"view": "front"}}\n',
     'error: /camera/view: needs /camera/frame')
case('azimuth-without-frame.json', '{"camera": {"azimuth": 90}}\n',
     'error: /camera/azimuth: needs /camera/frame')
case('frame-azimuth-range.json',
     '{"camera": {"frame": "all", "azimuth": 400}, "objects": [{"type": "sphere"}]}\n',
     'error: /camera/azimuth: must be <= 360')
case('frame-elevation-range.json',
     '{"camera": {"frame": "all", "elevation": -95}, "objects": [{"type": "sphere"}]}\n',
     'error: /camera/elevation: must be >= -90')
case('frame-elevation-type.json',
     '{"camera": {"frame": "all", "elevation": "high"}, "objects": [{"type": "sphere"}]}\n',
     'error: /camera/elevation: must be a number, not a string')
case('aperture-orthographic.json', '{"camera": {"projection": "orthographic", "aperture": 0.1}}\n',
     'error: /camera/aperture: must be 0 with an orthographic projection')
case('roughness-over-1.json', '{"materials": {"m": {"roughness": 1.5}}}\n',
     'error: /materials/m/roughness: must be <= 1')
case('metallic-negative.json', '{"materials": {"m": {"metallic": -1}}}\n',
     'error: /materials/m/metallic: must be >= 0')
case('texture-string.json', '{"materials": {"m": {"texture": "wood"}}}\n',
     'error: /materials/m/texture: must be an object, not a string')
case('texture-unknown-type.json', '{"materials": {"m": {"texture": {"type": "marble"}}}}\n',
     'error: /materials/m/texture/type: unknown type "marble" (supported: checker, stripes, gradient, image)')
case('texture-missing-type.json', '{"materials": {"m": {"texture": {"scale": 2}}}}\n',
     'error: /materials/m/texture/type: is required')
case('texture-unknown-key.json', '{"materials": {"m": {"texture": {"type": "checker", "size": 2}}}}\n',
     'error: /materials/m/texture/size: unknown key (allowed here: type, colors, scale, space, axis, png_base64, file)')
case('texture-three-colors.json', '{"materials": {"m": {"texture": {"type": "checker", "colors": [[1, 1, 1], [0, 0, 0], [1, 0, 0]]}}}}\n',
     'error: /materials/m/texture/colors: must be an array of 2 colours')
case('texture-color-negative.json', '{"materials": {"m": {"texture": {"type": "checker", "colors": [[1, 1, 1], [0, -1, 0]]}}}}\n',
     'error: /materials/m/texture/colors/1/1: must be >= 0')
case('texture-scale-zero.json', '{"materials": {"m": {"texture": {"type": "checker", "scale": 0}}}}\n',
     'error: /materials/m/texture/scale: must be > 0')
case('texture-space-unknown.json', '{"materials": {"m": {"texture": {"type": "checker", "space": "screen"}}}}\n',
     'error: /materials/m/texture/space: unknown value "screen" (supported: object, world, uv)')
case('texture-axis-zero.json', '{"materials": {"m": {"texture": {"type": "stripes", "axis": [0, 0, 0]}}}}\n',
     'error: /materials/m/texture/axis: must not be a zero-length vector')
case('texture-image-no-data.json', '{"materials": {"m": {"texture": {"type": "image"}}}}\n',
     'error: /materials/m/texture: an image texture needs exactly one of "png_base64" or "file"')
case('texture-checker-with-png.json', '{"materials": {"m": {"texture": {"type": "checker", "png_base64": "AAAA"}}}}\n',
     'error: /materials/m/texture: png_base64 and file belong to image textures')
case('texture-image-not-png.json', '{"materials": {"m": {"texture": {"type": "image", "png_base64": "aGVsbG8gd29ybGQ="}}}}\n',
     'error: /materials/m/texture/png_base64: not a readable PNG: Not a PNG file')
case('texture-image-bad-base64.json', '{"materials": {"m": {"texture": {"type": "image", "png_base64": "!!!!"}}}}\n',
     "error: /materials/m/texture/png_base64: base64: invalid character '!' at offset 0")
case('texture-image-missing-file.json', '{"materials": {"m": {"texture": {"type": "image", "file": "no-such.png"}}}}\n',
     'error: /materials/m/texture/file: cannot open "no-such.png": No such file or directory')
case('area-shape-unknown.json', '{"lights": [{"type": "area", "shape": "triangle"}]}\n',
     'error: /lights/0/shape: unknown value "triangle" (supported: rectangle, disc, sphere)')
case('area-samples-zero.json', '{"lights": [{"type": "area", "samples": 0}]}\n',
     'error: /lights/0/samples: must be >= 1')
case('area-samples-over.json', '{"lights": [{"type": "area", "samples": 1025}]}\n',
     "error: /lights/0/samples: must be <= 1024 (the limit)")
case('area-radius-zero.json', '{"lights": [{"type": "area", "shape": "disc", "radius": 0}]}\n',
     'error: /lights/0/radius: must be > 0')
case('area-edges-parallel.json', '{"lights": [{"type": "area", "edge1": [1, 0, 0], "edge2": [2, 0, 0]}]}\n',
     'error: /lights/0/edge2: must not be parallel to edge1')
case('area-normal-zero.json', '{"lights": [{"type": "area", "shape": "disc", "normal": [0, 0, 0]}]}\n',
     'error: /lights/0/normal: must not be a zero-length vector')
case('area-direction-key.json', '{"lights": [{"type": "area", "direction": [0, -1, 0]}]}\n',
     'error: /lights/0/direction: unknown key (allowed here: type, shape, position, edge1, edge2, normal, radius, color, intensity, samples)')
case('box-both-forms.json', '{"objects": [{"type": "box", "min": [0, 0, 0], "size": [1, 1, 1]}]}\n',
     'error: /objects/0: give either min and max, or center and size')
case('box-max-below-min.json', '{"objects": [{"type": "box", "min": [0, 0, 0], "max": [1, 0, 1]}]}\n',
     'error: /objects/0/max: must be greater than min in every axis')
case('box-size-negative.json', '{"objects": [{"type": "box", "size": [1, -1, 1]}]}\n',
     'error: /objects/0/size: must be > 0 in every axis')
case('cylinder-top-equals-base.json', '{"objects": [{"type": "cylinder", "base": [0, 1, 0], "top": [0, 1, 0]}]}\n',
     'error: /objects/0/top: must differ from base')
case('cylinder-radius-zero.json', '{"objects": [{"type": "cylinder", "radius": 0}]}\n',
     'error: /objects/0/radius: must be > 0')
case('cylinder-capped-string.json', '{"objects": [{"type": "cylinder", "capped": "yes"}]}\n',
     'error: /objects/0/capped: must be true or false, not a string')
case('cone-radii-zero.json', '{"objects": [{"type": "cone", "base_radius": 0, "top_radius": 0}]}\n',
     'error: /objects/0/base_radius: base_radius or top_radius must be > 0')
case('cone-radius-key.json', '{"objects": [{"type": "cone", "radius": 1}]}\n',
     'error: /objects/0/radius: unknown key (allowed here: type, name, material, transform, base, top, base_radius, top_radius, capped)')
case('disc-inner-over-radius.json', '{"objects": [{"type": "disc", "radius": 1, "inner_radius": 2}]}\n',
     'error: /objects/0/inner_radius: must be <= 1')
case('disc-normal-zero.json', '{"objects": [{"type": "disc", "normal": [0, 0, 0]}]}\n',
     'error: /objects/0/normal: must not be a zero-length vector')
case('torus-minor-over-major.json', '{"objects": [{"type": "torus", "major_radius": 1, "minor_radius": 2}]}\n',
     'error: /objects/0/minor_radius: must be <= major_radius')
case('torus-axis-zero.json', '{"objects": [{"type": "torus", "axis": [0, 0, 0]}]}\n',
     'error: /objects/0/axis: must not be a zero-length vector')
case('triangle-missing-vertices.json', '{"objects": [{"type": "triangle"}]}\n',
     'error: /objects/0/vertices: is required (three [x, y, z] points)')
case('triangle-two-points.json', '{"objects": [{"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0]]}]}\n',
     'error: /objects/0/vertices: must be an array of 3 points')
case('triangle-flat-numbers.json', '{"objects": [{"type": "triangle", "vertices": [0, 0, 0, 1, 0, 0, 0, 1, 0]}]}\n',
     'error: /objects/0/vertices: must be an array of 3 points')
case('triangle-collinear.json', '{"objects": [{"type": "triangle", "vertices": [[0, 0, 0], [1, 1, 1], [2, 2, 2]]}]}\n',
     'error: /objects/0/vertices: must not be collinear (the triangle has no area)')
case('quad-edges-parallel.json', '{"objects": [{"type": "quad", "edge1": [1, 0, 0], "edge2": [-3, 0, 0]}]}\n',
     'error: /objects/0/edge2: must not be parallel to edge1')
case('quad-edge-zero.json', '{"objects": [{"type": "quad", "edge1": [0, 0, 0]}]}\n',
     'error: /objects/0/edge1: must not be a zero-length vector')
case('quadric-missing.json', '{"objects": [{"type": "quadric"}]}\n',
     'error: /objects/0/coefficients: is required: 10 numbers a..j of a x^2 + b y^2 + c z^2 + d xy + e xz + f yz + g x + h y + i z + j')
case('quadric-nine.json', '{"objects": [{"type": "quadric", "coefficients": [1, 1, 1, 0, 0, 0, 0, 0, 0]}]}\n',
     'error: /objects/0/coefficients: is required: 10 numbers a..j of a x^2 + b y^2 + c z^2 + d xy + e xz + f yz + g x + h y + i z + j')
case('quadric-zero.json', '{"objects": [{"type": "quadric", "coefficients": [0, 0, 0, 0, 0, 0, 0, 0, 0, -1]}]}\n',
     'error: /objects/0/coefficients: must not all be zero (but j)')
case('quadric-huge.json', '{"objects": [{"type": "quadric", "coefficients": [1, 1, 1, 0, 0, 0, 0, 0, 0, -2e9]}]}\n',
     'error: /objects/0/coefficients/9: must be in [-1e9, 1e9]')
# Every array of numbers says the same three things: not a number (and what
# it is), not finite, out of range.
case('quadric-string.json', '{"objects": [{"type": "quadric", "coefficients": [1, 1, 1, "0", 0, 0, 0, 0, 0, -2]}]}\n',
     'error: /objects/0/coefficients/3: must be a number, not a string')
case('csg-no-op.json', '{"objects": [{"type": "csg", "operands": [{"type": "sphere"}, {"type": "box"}]}]}\n',
     'error: /objects/0/op: is required (union, intersection or difference)')
case('csg-unknown-op.json', '{"objects": [{"type": "csg", "op": "xor", "operands": [{"type": "sphere"}, {"type": "box"}]}]}\n',
     'error: /objects/0/op: unknown value "xor" (supported: union, intersection, difference)')
case('csg-one-operand.json', '{"objects": [{"type": "csg", "op": "union", "operands": [{"type": "sphere"}]}]}\n',
     'error: /objects/0/operands: must be an array of at least 2 objects')
case('csg-operand-disc.json', '{"objects": [{"type": "csg", "op": "difference", "operands": [{"type": "sphere"}, {"type": "disc"}]}]}\n',
     'error: /objects/0/operands/1/type: a disc cannot be a CSG operand: CSG needs closed solids (sphere, box, capped cylinder or cone, torus, plane, quadric, csg)')
case('csg-operand-open-cylinder.json', '{"objects": [{"type": "csg", "op": "union", "operands": [{"type": "sphere"}, {"type": "cylinder", "capped": false}]}]}\n',
     'error: /objects/0/operands/1/capped: an open cylinder cannot be a CSG operand: CSG needs closed solids (sphere, box, capped cylinder or cone, torus, plane, quadric, csg)')
# the message said "a cylinder" (which may be an operand, capped) and "a instance"
case('csg-operand-open-cone.json', '{"objects": [{"type": "csg", "op": "union", "operands": [{"type": "sphere"}, {"type": "cone", "capped": false}]}]}\n',
     'error: /objects/0/operands/1/capped: an open cone cannot be a CSG operand: CSG needs closed solids (sphere, box, capped cylinder or cone, torus, plane, quadric, csg)')
case('csg-operand-instance.json', '{"groups": {"g": [{"type": "sphere"}]}, "objects": [{"type": "csg", "op": "union", "operands": [{"type": "sphere"}, {"type": "instance", "group": "g"}]}]}\n',
     'error: /objects/0/operands/1/type: an instance cannot be a CSG operand: CSG needs closed solids (sphere, box, capped cylinder or cone, torus, plane, quadric, csg)')
case('csg-operand-bad.json', '{"objects": [{"type": "csg", "op": "union", "operands": [{"type": "sphere"}, {"type": "sphere", "radius": -1}]}]}\n',
     'error: /objects/0/operands/1/radius: must be > 0')
case('instance-no-group.json', '{"objects": [{"type": "instance"}]}\n',
     'error: /objects/0/group: is required: the name of a group in /groups')
case('instance-unknown-group.json', '{"groups": {"tree": [{"type": "sphere"}]}, "objects": [{"type": "instance", "group": "house"}]}\n',
     'error: /objects/0/group: unknown group "house" (not a key of /groups)')
case('instance-in-group.json', '{"groups": {"a": [{"type": "sphere"}], "b": [{"type": "instance", "group": "a"}]}}\n',
     'error: /groups/b/0/type: an instance cannot be inside a group (groups do not nest)')
case('group-empty.json', '{"groups": {"tree": []}}\n',
     'error: /groups/tree: must not be empty')
case('group-plane.json', '{"groups": {"ground": [{"type": "sphere"}, {"type": "plane"}]}}\n',
     'error: /groups/ground/1: unbounded objects (planes, quadrics) cannot be in a group')
case('groups-array.json', '{"groups": [{"type": "sphere"}]}\n',
     'error: /groups: must be an object, not an array')
case('group-not-array.json', '{"groups": {"tree": {"type": "sphere"}}}\n',
     'error: /groups/tree: must be an array, not an object')
case('group-member-bad.json', '{"groups": {"tree": [{"type": "sphere", "radius": 0}]}}\n',
     'error: /groups/tree/0/radius: must be > 0')
case("csg-33-operands.json", '{"objects": [{"type": "csg", "op": "union", "operands": ['
     + ", ".join(['{"type": "sphere"}'] * 33) + ']}]}\n',
     'error: /objects/0/operands: has 33 operands; the limit is 32')

# ---- once loader bugs, now fixed: each stays here as a regression case ------------
# \u0000 in a string: cJSON would cut the string at the NUL and read
# "sphere", "width" and "red"; the syntax check refuses it.
case("nul-escape-in-type.json", '{"objects": [{"type": "sphere\\u0000junk"}]}\n',
     E + "line 1, column 30: malformed JSON: \\u0000 (NUL) is not allowed in strings")
case("nul-escape-in-key.json", '{"render": {"width\\u0000x": 64}}\n',
     E + "line 1, column 19: malformed JSON: \\u0000 (NUL) is not allowed in strings")
case("nul-escape-in-material-ref.json",
     '{"materials": {"red": {}}, "objects": [{"type": "sphere", "material": "red\\u0000x"}]}\n',
     E + "line 1, column 75: malformed JSON: \\u0000 (NUL) is not allowed in strings")
# An escaped newline in a key stays escaped: the message is one line.
case("newline-in-unknown-key.json", '{"camera": {"a\\nb": 1}}\n',
     E + "/camera/a\\u000ab: unknown key (allowed here: position, look_at, up, fov_x, fov_y, projection, view_width, aperture, focus_distance, frame, view, azimuth, elevation)")
# A NUL byte inside the text is named.
d = b'{"render":\n  {"width": 6\x004}}\n'
case("nul-byte.json", d, E + at(d, b"\x00") + ": malformed JSON: expected ',' or '}', found byte 0x00 (NUL)")
# The product of transform steps is checked, not only each step.
steps = ", ".join(['{"scale": 1e9}'] * 40)
case("transform-steps-overflow.json", xf("[%s]" % steps),
     E + "/objects/0/transform: must not scale the object by more than 1e9 or less than 1e-9 (all steps together)")
steps = ", ".join(['{"scale": 1e-9}'] * 40)
case("transform-steps-underflow.json", xf("[%s]" % steps),
     E + "/objects/0/transform: must not scale the object by more than 1e9 or less than 1e-9 (all steps together)")
# Matrix entries have the same bound as translate.
case("transform-matrix-huge-translation.json",
     xf('{"matrix": [1, 0, 0, 1e300, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}'),
     E + "/objects/0/transform/matrix/3: must be in [-1e9, 1e9]")
case("transform-matrix-null.json",
     xf('{"matrix": [1, 0, 0, 0, 0, 1, 0, null, 0, 0, 1, 0, 0, 0, 0, 1]}'),
     E + "/objects/0/transform/matrix/7: must be a number, not null")
# Mesh numbers: out of range and not a number are told apart.
case("mesh-vertex-huge.json", mesh('"vertices": [0, 0, 0, 1e31, 0, 0, 0, 1, 0], "indices": [0, 1, 2]'),
     E + "/objects/0/vertices/3: must be in [-1e30, 1e30]")
case("mesh-vertex-string.json", mesh('"vertices": [0, 0, 0, "1", 0, 0, 0, 1, 0], "indices": [0, 1, 2]'),
     E + "/objects/0/vertices/3: must be a number, not a string")
case("instance-material.json", '{"groups": {"g": [{"type": "sphere"}]}, "objects": [{"type": "instance", "group": "g", "material": {}}]}\n',
     E + "/objects/0/material: unknown key (allowed here: type, name, transform, group)")
case("bom.json", b'\xef\xbb\xbf{}\n', E + "line 1, column 1: malformed JSON: a byte order mark (BOM) is not allowed; save the file as UTF-8 without BOM")
case("number-two-dots.json", '{"render": {"width": 1.5.3}}\n', E + "line 1, column 25: malformed JSON: invalid number")
case("mesh-file-empty-name.json", mesh('"source": {"format": "obj", "file": ""}'), E + "/objects/0/source/file: must not be empty")

case("environment-array.json", '{"render": {"environment": [1, 1, 1]}}\n',
     E + "/render/environment: must be an object, not an array")
case("environment-two-sources.json", '{"render": {"environment": {"color": [1, 1, 1], "file": "sky.hdr"}}}\n',
     E + '/render/environment: needs exactly one of "color", "file" or "base64"')
case("environment-negative-intensity.json", '{"render": {"environment": {"color": [1, 1, 1], "intensity": -2}}}\n',
     E + "/render/environment/intensity: must be >= 0")
case("environment-unknown-key.json", '{"render": {"environment": {"color": [1, 1, 1], "exposure": 2}}}\n',
     E + "/render/environment/exposure: unknown key (allowed here: color, file, base64, format, rotation, intensity, visible)")
case("environment-missing-file.json", '{"render": {"environment": {"file": "no-such-sky.hdr"}}}\n',
     E + '/render/environment/file: cannot open "no-such-sky.hdr": No such file or directory')
case("environment-not-hdr.json", '{"render": {"environment": {"file": "empty.json"}}}\n',
     E + '/render/environment/file: is not a Radiance .hdr image (it must start with "#?RADIANCE" or "#?RGBE")')
case("environment-base64-png.json", '{"render": {"environment": {"base64": "iVBORw0KGgo=", "format": "png"}}}\n',
     E + '/render/environment/format: unknown value "png" (supported: hdr, exr)')


def rle_hdr(w, h):
    """A w x h new-style RLE .hdr: each component of a scanline one run."""
    out = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w)
    for _ in range(h):
        out += bytes([2, 2, w >> 8, w & 255])
        for v in (128, 100, 60, 129):
            out += bytes([128 + w, v])
    return out


def env_b64(data):
    b64 = base64.b64encode(data).decode()
    return '{"render": {"environment": {"base64": "%s"}}, "objects": []}\n' % b64


import base64  # noqa: E402
# A download cut short: stb_image reads zeros past the end, each a no-op
# run count, and spun for ever on them.  Cut after row 3's header and first run.
RLE = rle_hdr(16, 8)
HDR_HEAD = RLE.index(b"+X 16\n") + len(b"+X 16\n")
case("environment-hdr-truncated.json", env_b64(RLE[:HDR_HEAD + 3 * 12 + 6]),
     E + "/render/environment/base64: the .hdr image's data ends early (it stops in row 3 of 8)")
FLAT = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 4\n" + bytes([128, 128, 128, 129]) * 10
case("environment-hdr-flat-truncated.json", env_b64(FLAT),
     E + "/render/environment/base64: the .hdr image's data ends early (it stops in row 2 of 4)")
# Headers stb_image refuses were all "unknown image type" (or a start the
# file has): each now says what in the header is wrong.
PIX = bytes([128, 128, 128, 129]) * 16
case("environment-hdr-no-format.json", env_b64(b"#?RADIANCE\n\n-Y 4 +X 4\n" + PIX),
     E + "/render/environment/base64: is not a readable .hdr image: its header has no "
     "FORMAT=32-bit_rle_rgbe line (stb_image reads only that format)")
case("environment-hdr-xyze.json",
     env_b64(b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 4 +X 4\n" + PIX),
     E + "/render/environment/base64: is not a readable .hdr image: its format is "
     "'32-bit_rle_xyze'; only 32-bit_rle_rgbe is read")
case("environment-hdr-plus-y.json",
     env_b64(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 4 +X 4\n" + PIX),
     E + "/render/environment/base64: is not a readable .hdr image: its resolution line is "
     "'+Y 4 +X 4'; only '-Y H +X W' (rows from the top, each from the left) is read")
case("environment-hdr-crlf.json",
     env_b64(b"#?RADIANCE\r\nFORMAT=32-bit_rle_rgbe\r\n\r\n-Y 4 +X 4\r\n" + PIX),
     E + "/render/environment/base64: is not a Radiance .hdr image (its lines end in CR LF; "
     "a .hdr header's lines end in LF)")


# ---- animation: the /animation block and keyframes, in cases_anim.py ----
sys.path.insert(0, HERE)
import cases_anim  # noqa: E402 (after HERE is on the path)

cases_anim.add(case)


def main():
    os.makedirs(OUT, exist_ok=True)
    names = set()
    lines = []
    for name, data, expected, bug in CASES:
        assert name not in names, name
        names.add(name)
        with open(os.path.join(OUT, name), "wb") as f:
            f.write(data)
        assert "\t" not in expected and "\n" not in expected
        lines.append("\t".join([name, "1", PREFIX + expected] + (["bug"] if bug else [])))
    for old in os.listdir(OUT):
        if old not in names:
            os.remove(os.path.join(OUT, old))
    with open(os.path.join(HERE, "scenes.tsv"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("%d files, %d marked bug" % (len(CASES), sum(1 for c in CASES if c[3])))


if __name__ == "__main__":
    main()
