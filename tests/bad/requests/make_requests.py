#!/usr/bin/env python3
"""make_requests.py -- writes the bad-HTTP-request corpus: tests/bad/requests/
cases/*.http (the raw bytes sent on one TCP connection) and manifest.tsv.

Run from anywhere:  python3 tests/bad/requests/make_requests.py
Edit the CASES below, not the generated files, then run it again.
tests/integration/bad_requests.sh sends every file to a real rayd started as

    rayd --port 0 --threads 2 --max-body 65536 --max-pixels 1000000
         --max-url 4096 --timeout 2 --token-file <a file holding TOKEN>

(every request carries the right bearer token unless the case is about the
Authorization header), and checks the answer and that GET /healthz still
answers 200 after each.

manifest.tsv columns:
  name      the file cases/NAME.http
  status    the HTTP status expected, or `close`: the connection is closed
            without an answer (a truncated request the client gave up on)
  code      the API error code of the JSON body ({"error": {"status",
            "code", "message"}}), or `-` when libmicrohttpd refuses the
            request itself, before rayd's code runs (then the body is its
            own short HTML page and only the status is checked)
  shut      `shut`: the client half-closes after sending (truncated
            requests); `-`: it waits for the answer
  what      one line saying what is wrong
"""
import json
import os
import shutil

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "cases")
TOKEN = "corpus-T0ken"
AUTH = "Authorization: Bearer %s\r\n" % TOKEN
MAX_BODY = 65536

CASES = []  # (name, raw bytes, status, code, shut, what)


def raw(name, data, status, code, what, shut=False):
    assert name not in [c[0] for c in CASES], name
    CASES.append((name, data, str(status), code, "shut" if shut else "-", what))


def request(method, target, body=None, headers=None, ctype="application/json", auth=True,
            length=True, version="HTTP/1.1"):
    """A well-framed request with Host, the token, Connection: close."""
    if isinstance(body, str):
        body = body.encode("utf-8")
    h = "%s %s %s\r\nHost: 127.0.0.1\r\n" % (method, target, version)
    if auth:
        h += AUTH
    if body is not None and ctype is not None:
        h += "Content-Type: %s\r\n" % ctype
    if body is not None and length:
        h += "Content-Length: %d\r\n" % len(body)
    for x in headers or []:
        h += x + "\r\n"
    h += "Connection: close\r\n\r\n"
    return h.encode("latin-1") + (body or b"")


def post(name, body, status, code, what, target="/v1/render", **kw):
    raw(name, request("POST", target, body, **kw), status, code, what)


SCENE = {
    "camera": {"position": [0, 1, 6], "look_at": [0, 1, 0], "up": [0, 1, 0], "fov_x": 60},
    "render": {"width": 64, "height": 48, "samples": 1, "max_depth": 2},
    "materials": {"red": {"color": [0.9, 0.1, 0.1]}},
    "lights": [{"type": "point", "position": [5, 8, 5]}],
    "objects": [
        {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0]},
        {"type": "sphere", "center": [0, 1, 0], "radius": 1, "material": "red"},
    ],
}
GOOD = json.dumps(SCENE)


def scene_with(path, value):
    """SCENE with one value replaced (path: list of keys/indexes)."""
    s = json.loads(GOOD)
    o = s
    for k in path[:-1]:
        o = o[k]
    o[path[-1]] = value
    return json.dumps(s)


def scene_text_with(old, new):
    assert old in GOOD, old
    return GOOD.replace(old, new, 1)


# ---- malformed and truncated JSON: 400 invalid_json ------------------------------------
for name, body in [
    ("json-open-brace", "{"),
    ("json-truncated-key", '{"camera":'),
    ("json-truncated-half", GOOD[: len(GOOD) // 2]),
    ("json-truncated-last-byte", GOOD[:-1]),
    ("json-array-open", "[1,2,"),
    ("json-missing-colon", '{"camera" 1}'),
    ("json-trailing-comma", '{"render": {"width": 64,}}'),
    ("json-single-quotes", "{'camera': 1}"),
    ("json-nan-literal", scene_text_with('"radius": 1', '"radius": NaN')),
    ("json-infinity-literal", scene_text_with('"radius": 1', '"radius": Infinity')),
    ("json-comment", "// a comment\n" + GOOD),
    ("json-leading-zero", scene_text_with('"radius": 1', '"radius": 01')),
    ("json-trailing-garbage", GOOD + "{}"),
    ("json-two-documents", GOOD + "\n" + GOOD),
    ("json-empty-body", ""),
    ("json-whitespace-only", " \n\t \r\n"),
    ("json-control-char-in-string", '{"camera": "a\x01b"}'),
    ("json-unterminated-string", '{"camera": "abc'),
    ("json-bad-escape", '{"camera": "\\q"}'),
    ("json-short-unicode-escape", '{"camera": "\\u12"}'),
    ("json-bare-word", "hello"),
    ("json-plus-number", scene_text_with('"radius": 1', '"radius": +1')),
    ("json-hex-number", scene_text_with('"radius": 1', '"radius": 0x1')),
    ("json-dot-number", scene_text_with('"radius": 1', '"radius": .5')),
    ("json-unclosed-array", scene_text_with('"look_at": [0, 1, 0]', '"look_at": [0, 1, 0')),
    ("json-nul-byte", '{"camera": 1}\x00'),
]:
    post(name, body, 400, "invalid_json", "malformed JSON: " + name[5:])

# ---- deep nesting ------------------------------------------------------------------------
# the loader refuses nesting past 64 levels as malformed JSON, at the 65th
post("nest-array-open-60000", "[" * 60000, 400, "invalid_json", "60,000 unclosed [")
post("nest-array-closed-5000", "[" * 5000 + "]" * 5000, 400, "invalid_json", "arrays nested 5,000 deep")
post("nest-object-2000", '{"a":' * 2000 + "1" + "}" * 2000, 400, "invalid_json", "objects nested 2,000 deep")
post("nest-in-render-200", scene_text_with('"samples": 1', '"samples": ' + "[" * 200 + "]" * 200),
     400, "invalid_json", "a value nested 200 deep inside render")
post("nest-mixed-open-30000", '[{"a":' * 10000, 400, "invalid_json", "10,000 unclosed [{ pairs")

# ---- huge arrays and strings (under --max-body) ------------------------------------------
post("huge-objects-array", scene_text_with('"objects": [', '"objects": [' + "0," * 30000),
     422, "invalid_scene", "30,000 numbers where objects belong")
post("huge-lights-array", scene_with(["lights"], [{"type": "point", "position": [0, 5, 0]}] * 1200),
     413, "too_large", "1,200 lights")
post("huge-string-value", scene_with(["objects", 1, "material"], "m" * 60000), 422,
     "invalid_scene", "a 60,000-byte material name")
post("huge-string-key", scene_text_with('"render": {', '"render": {"' + "k" * 60000 + '": 1, '),
     422, "invalid_scene", "a 60,000-byte unknown key")
post("huge-vector", scene_with(["camera", "position"], [0] * 20000), 422, "invalid_scene",
     "a 20,000-element position vector")
post("huge-inline-materials", scene_with(["objects"], [{"type": "sphere", "center": [0, 0, 0], "radius": 1,
                                                       "material": {"color": [1, 1, 1], "x": 1}}] * 600),
     422, "invalid_scene", "600 spheres, the first with an unknown key in its inline material")

# ---- numbers out of range and non-finite -----------------------------------------------------
for name, path, value, status, code in [
    ("num-width-1e400", ["render", "width"], "1e400", 422, "invalid_scene"),
    ("num-width-negative", ["render", "width"], "-64", 422, "invalid_scene"),
    ("num-width-zero", ["render", "width"], "0", 422, "invalid_scene"),
    ("num-width-fraction", ["render", "width"], "64.5", 422, "invalid_scene"),
    ("num-width-int-overflow", ["render", "width"], "4294967360", 413, "too_large"),
    ("num-radius-huge-exponent", ["objects", 1, "radius"], "1e999", 422, "invalid_scene"),
    ("num-radius-negative", ["objects", 1, "radius"], "-1", 422, "invalid_scene"),
    ("num-radius-zero", ["objects", 1, "radius"], "0", 422, "invalid_scene"),
    ("num-position-overflow", ["camera", "position"], "[1e309, 0, 0]", 422, "invalid_scene"),
    ("num-samples-huge", ["render", "samples"], "1000000000", 413, "too_large"),
    ("num-depth-huge", ["render", "max_depth"], "100000", 413, "too_large"),
    ("num-fov-180", ["camera", "fov_x"], "180", 422, "invalid_scene"),
    ("num-fov-zero", ["camera", "fov_x"], "0", 422, "invalid_scene"),
    ("num-fov-negative", ["camera", "fov_x"], "-10", 422, "invalid_scene"),
    ("num-seed-negative", ["render", "seed"], "-1", 422, "invalid_scene"),
    ("num-intensity-negative", ["lights", 0, "intensity"], "-1", 422, "invalid_scene"),
    ("num-color-negative", ["materials", "red", "color"], "[-1, 0, 0]", 422, "invalid_scene"),
    ("num-normal-zero-length", ["objects", 0, "normal"], "[0, 0, 0]", 422, "invalid_scene"),
    ("num-up-parallel", ["camera", "up"], "[0, 0, 0]", 422, "invalid_scene"),
    ("num-height-1e-300", ["render", "height"], "1e-300", 422, "invalid_scene"),
]:
    body = scene_with(path, "@@")
    body = body.replace('"@@"', value)
    post(name, body, status, code, "%s = %s" % ("/".join(map(str, path)), value[:20]))

# ---- wrong types -----------------------------------------------------------------------------------
for name, path, value in [
    ("type-camera-number", ["camera"], 1),
    ("type-render-array", ["render"], []),
    ("type-width-string", ["render", "width"], "64"),
    ("type-objects-object", ["objects"], {}),
    ("type-position-string-element", ["camera", "position"], [0, "a", 0]),
    ("type-material-number", ["objects", 1, "material"], 5),
    ("type-radius-bool", ["objects", 1, "radius"], True),
    ("type-radius-null", ["objects", 1, "radius"], None),
    ("type-lights-string", ["lights"], "point"),
    ("type-object-type-number", ["objects", 1, "type"], 3),
]:
    post(name, scene_with(path, value), 422, "invalid_scene", "wrong type at /" + "/".join(map(str, path)))
for name, body in [("type-top-null", "null"), ("type-top-array", "[]"), ("type-top-string", '"scene"'),
                   ("type-top-number", "42"), ("type-top-true", "true")]:
    post(name, body, 422, "invalid_scene", "the document is not an object")

# ---- duplicate and unknown keys ---------------------------------------------------------------------
post("dup-top-camera", scene_text_with('"render":', '"camera": {}, "render":'), 422, "invalid_scene",
     "camera given twice")
post("dup-render-width", scene_text_with('"width": 64', '"width": 64, "width": 32'), 422,
     "invalid_scene", "render.width given twice")
post("dup-object-radius", scene_text_with('"radius": 1', '"radius": 1, "radius": 2'), 422,
     "invalid_scene", "radius given twice")
post("dup-material-name", scene_text_with('"materials": {', '"materials": {"red": {}, '), 422,
     "invalid_scene", "material red defined twice")
for name, path, key in [("unknown-top", [], "foo"), ("unknown-render", ["render"], "bogus"),
                        ("unknown-camera", ["camera"], "zoom"),
                        ("unknown-object", ["objects", 1], "colour"),
                        ("unknown-material", ["materials", "red"], "colr"),
                        ("unknown-light", ["lights", 0], "power")]:
    s = json.loads(GOOD)
    o = s
    for k in path:
        o = o[k]
    o[key] = 1
    post(name, json.dumps(s), 422, "invalid_scene", "unknown key %s" % key)
post("unknown-object-type", scene_with(["objects", 1, "type"], "cube"), 422, "invalid_scene",
     "object type cube")

# ---- invalid UTF-8 ---------------------------------------------------------------------------------------
g = GOOD.encode()
for name, bad in [("utf8-ff-byte", b"\xff"), ("utf8-overlong-slash", b"\xc0\xaf"),
                  ("utf8-lone-continuation", b"\x80"), ("utf8-surrogate", b"\xed\xa0\x80"),
                  ("utf8-truncated-sequence", b"\xe2\x82")]:
    body = g.replace(b'"red"', b'"r' + bad + b'd"', 1)  # in a material name (a key)
    raw(name, request("POST", "/v1/render", body), 400, "invalid_json", "invalid UTF-8 in a key")
raw("utf8-at-end", request("POST", "/v1/render", g[:-1] + b"\xc3"), 400, "invalid_json",
    "invalid UTF-8 as the last byte")
raw("utf8-bom-utf16", request("POST", "/v1/render", b"\xff\xfe" + GOOD.encode("utf-16-le")), 400,
    "invalid_json", "a UTF-16 body")

# ---- wrong methods ------------------------------------------------------------------------------------------
for name, method, target in [("method-get-render", "GET", "/v1/render"),
                             ("method-put-scenes", "PUT", "/v1/scenes"),
                             ("method-delete-render", "DELETE", "/v1/render"),
                             ("method-patch-jobs", "PATCH", "/v1/jobs"),
                             ("method-post-healthz", "POST", "/healthz"),
                             ("method-post-metrics", "POST", "/metrics"),
                             ("method-brew-root", "BREW", "/"),
                             ("method-trace-render", "TRACE", "/v1/render"),
                             ("method-lowercase-get", "get", "/healthz"),
                             ("method-post-scene-image", "POST",
                              "/v1/scenes/" + "0" * 64 + "/image.png"),
                             ("method-put-job", "PUT", "/v1/jobs/" + "0" * 32)]:
    raw(name, request(method, target), 405, "method_not_allowed", "%s %s" % (method, target))
# a method that is no RFC 9110 token is a malformed request, not an unknown method
for name, method in [("method-not-token-brace", "G{T"), ("method-not-token-quote", 'G"T'),
                     ("method-not-token-angle", "G<b>T"), ("method-not-token-comma", "G,T"),
                     ("method-not-token-control", "G\x01T"), ("method-not-token-utf8", "G\xc9T")]:
    raw(name, request(method, "/healthz"), 400, "bad_request", "%r /healthz" % method)
raw("method-not-token-with-body", request("P{ST", "/v1/render", GOOD), 400, "bad_request",
    "'P{ST' /v1/render with a body")
raw("method-long-token", request("A" * 300, "/healthz"), 405, "method_not_allowed",
    "a 300-byte method that is a token")

# ---- wrong content types: 415 ----------------------------------------------------------------------------------
for name, ctype, target in [("ctype-missing", None, "/v1/render"),
                            ("ctype-text-plain", "text/plain", "/v1/render"),
                            ("ctype-form", "application/x-www-form-urlencoded", "/v1/render"),
                            ("ctype-multipart", "multipart/form-data; boundary=x", "/v1/scenes"),
                            ("ctype-jsonx", "application/jsonx", "/v1/render"),
                            ("ctype-json-patch", "application/json-patch+json", "/v1/jobs"),
                            ("ctype-empty", "", "/v1/render"),
                            ("ctype-json-prefix-space", "application/ json", "/v1/scenes")]:
    raw(name, request("POST", target, GOOD, ctype=ctype), 415, "unsupported_media_type",
        "Content-Type %r" % ctype)

# ---- oversized bodies and images: 413 -----------------------------------------------------------------------------
raw("size-length-over-limit", request("POST", "/v1/render", GOOD,
                                      headers=["Content-Length: %d" % (MAX_BODY + 1)], length=False),
    413, "body_too_large", "Content-Length one over --max-body (refused before the body)")
raw("size-length-1e20", request("POST", "/v1/render", GOOD, headers=["Content-Length: 100000000000000000000"],
                                length=False), 413, "-", "Content-Length 10^20 (libmicrohttpd: over 64 bits)")
raw("size-body-over-limit", request("POST", "/v1/render", GOOD + " " * MAX_BODY), 413,
    "body_too_large", "a body one scene over --max-body")
big = (GOOD + " " * (MAX_BODY + 100)).encode()
chunks = b"".join(b"%x\r\n%s\r\n" % (len(big[i:i + 8192]), big[i:i + 8192]) for i in range(0, len(big), 8192))
raw("size-chunked-over-limit", request("POST", "/v1/render", chunks + b"0\r\n\r\n",
                                       headers=["Transfer-Encoding: chunked"], length=False),
    413, "body_too_large", "a chunked body that grows past --max-body")
raw("size-expect-continue", request("POST", "/v1/render", b"", headers=["Content-Length: 999999",
                                                                          "Expect: 100-continue"],
                                    length=False), 413, "body_too_large",
    "Expect: 100-continue with a body over the limit")
post("size-image-over-max-pixels", scene_with(["render", "width"], 2000).replace('"height": 48', '"height": 1000'),
     413, "too_large", "2000 x 1000 over --max-pixels 1000000")
post("size-image-on-jobs", scene_with(["render", "width"], 1001).replace('"height": 48', '"height": 1000'),
     413, "too_large", "jobs: 1001 x 1000 over --max-pixels", target="/v1/jobs")
post("size-image-on-scenes", scene_with(["render", "height"], 100000), 413, "too_large",
     "scenes: 64 x 100000 over --max-pixels", target="/v1/scenes")

# ---- bad regions and ids ------------------------------------------------------------------------------------------------
for name, query, code in [("region-x-negative", "x=-1&y=0&w=8&h=8", "bad_region"),
                          ("region-w-zero", "x=0&y=0&w=0&h=8", "bad_region"),
                          ("region-x-abc", "x=abc&y=0&w=8&h=8", "bad_region"),
                          ("region-w-huge", "x=0&y=0&w=99999999999999999999&h=8", "bad_region"),
                          ("region-x-repeated", "x=0&x=1&y=0&w=8&h=8", "bad_region"),
                          ("region-h-missing", "x=0&y=0&w=8", "bad_region"),
                          ("region-unknown-param", "x=0&y=0&w=8&h=8&zoom=2", "bad_parameter"),
                          ("region-x-float", "x=1.0&y=0&w=8&h=8", "bad_region"),
                          ("region-x-plus", "x=%2B1&y=0&w=8&h=8", "bad_region"),
                          ("region-x-space", "x=%201&y=0&w=8&h=8", "bad_region"),
                          ("region-y-empty", "x=0&y=&w=8&h=8", "bad_region"),
                          ("region-w-hex", "x=0&y=0&w=0x8&h=8", "bad_region"),
                          ("region-x-outside", "x=64&y=0&w=1&h=1", "bad_region"),
                          ("region-h-overflow", "x=0&y=40&w=8&h=9", "bad_region"),
                          ("region-w-int-wrap", "x=8&y=0&w=2147483647&h=8", "bad_region"),
                          ("region-x-nul", "x=0%00&y=0&w=8&h=8", "bad_region"),
                          ("region-valueless-x", "x&y=0&w=8&h=8", "bad_region"),
                          ("region-all-repeated-empty", "x=&y=&w=&h=", "bad_region")]:
    post(name, GOOD, 400, code, "region ?" + query, target="/v1/render?" + query)
post("region-on-jobs", GOOD, 400, "bad_region", "jobs region x=-5", target="/v1/jobs?x=-5&y=0&w=1&h=1")
raw("region-on-unknown-scene", request("GET", "/v1/scenes/" + "a" * 64 + "/image.png?x=-1"), 404,
    "scene_unknown", "region on a scene this node does not hold")
for name, target, code in [("id-job-short", "/v1/jobs/zzz", "job_unknown"),
                           ("id-job-33-hex", "/v1/jobs/" + "0" * 33, "job_unknown"),
                           ("id-job-uppercase", "/v1/jobs/" + "A" * 32, "job_unknown"),
                           ("id-job-image-unknown", "/v1/jobs/" + "1" * 32 + "/image.png", "job_unknown"),
                           ("id-job-events-unknown", "/v1/jobs/" + "2" * 32 + "/events", "job_unknown"),
                           ("id-job-too-long", "/v1/jobs/" + "f" * 200, "not_found"),
                           ("id-job-empty", "/v1/jobs//image.png", "not_found"),
                           ("id-scene-63-hex", "/v1/scenes/" + "0" * 63 + "/image.png", "scene_unknown"),
                           ("id-scene-dotdot", "/v1/scenes/../image.png", "scene_unknown"),
                           ("id-path-traversal", "/../../etc/passwd", "not_found"),
                           ("id-unknown-path", "/v2/render", "not_found")]:
    raw(name, request("GET", target), 404, code, "GET " + target[:60])
# a NUL or an encoded / in the path is refused before routing (RFC 9112)
for name, target in [("id-job-nul", "/v1/jobs/%00" + "0" * 31),
                     ("id-scene-encoded-slash", "/v1/scenes/a%2Fb/image.png"),
                     ("id-asset-traversal", "/..%2f..%2fetc%2fpasswd")]:
    raw(name, request("GET", target), 400, "bad_request", "GET " + target[:60])
raw("id-delete-unknown-job", request("DELETE", "/v1/jobs/" + "3" * 32), 404, "job_unknown",
    "DELETE of a job that never was")

# ---- header abuse ---------------------------------------------------------------------------------------------------------
raw("hdr-huge-header", request("GET", "/healthz", headers=["X-Big: " + "a" * 40000]), 431, "-",
    "one 40 KB header (libmicrohttpd: over its connection memory)")
raw("hdr-many-headers", request("GET", "/healthz", headers=["X-A%d: b" % i for i in range(5000)]), 431, "-",
    "5,000 headers (libmicrohttpd)")
raw("hdr-url-over-max-url", request("GET", "/healthz?" + "a" * 5000), 414, "uri_too_long",
    "a 5,000-byte target over --max-url 4096")
raw("hdr-url-over-memory", request("GET", "/healthz?" + "a" * 40000), 414, "-",
    "a 40 KB target (libmicrohttpd: over its connection memory)")
raw("hdr-length-abc", request("POST", "/v1/render", GOOD, headers=["Content-Length: abc"], length=False),
    400, "-", "Content-Length abc (libmicrohttpd)")
raw("hdr-length-negative", request("POST", "/v1/render", GOOD, headers=["Content-Length: -5"], length=False),
    400, "-", "Content-Length -5 (libmicrohttpd)")
raw("hdr-length-twice-differ", request("POST", "/v1/render", GOOD,
                                       headers=["Content-Length: %d" % len(GOOD), "Content-Length: 5"],
                                       length=False), 400, "bad_request",
    "two Content-Length headers that disagree (request smuggling)")
raw("hdr-length-and-chunked", request("POST", "/v1/render", b"5\r\nhello\r\n0\r\n\r\n",
                                      headers=["Content-Length: 20", "Transfer-Encoding: chunked"],
                                      length=False), 400, "bad_request",
    "Content-Length and Transfer-Encoding: chunked together (request smuggling)")
raw("hdr-chunked-twice", request("POST", "/v1/render", b"5\r\nhello\r\n0\r\n\r\n",
                                 headers=["Transfer-Encoding: chunked", "Transfer-Encoding: chunked"],
                                 length=False), 400, "bad_request", "Transfer-Encoding given twice")
# a Transfer-Encoding libmicrohttpd does not decode made it wait for
# --timeout and drop the connection unanswered
raw("hdr-te-gzip-chunked", request("POST", "/v1/render", b"5\r\nhello\r\n0\r\n\r\n",
                                   headers=["Transfer-Encoding: gzip, chunked"], length=False),
    501, "not_implemented", "a transfer coding before chunked (gzip, chunked)")
raw("hdr-te-chunked-gzip", request("POST", "/v1/render", b"5\r\nhello\r\n0\r\n\r\n",
                                   headers=["Transfer-Encoding: chunked, gzip"], length=False),
    400, "bad_request", "chunked not the last transfer coding (the body's length is unknown)")
raw("hdr-te-identity", request("POST", "/v1/render", GOOD, headers=["Transfer-Encoding: identity"],
                               length=False), 400, "bad_request",
    "Transfer-Encoding: identity (not chunked: the body's length is unknown)")
raw("hdr-te-on-get", request("GET", "/healthz", headers=["Transfer-Encoding: gzip"]), 400,
    "bad_request", "GET with Transfer-Encoding: gzip")
raw("hdr-host-twice", request("GET", "/healthz", headers=["Host: other.example"]), 400,
    "bad_request", "two Host headers (RFC 9112 section 3.2)")
raw("hdr-chunk-size-garbage", request("POST", "/v1/render", b"ZZZ\r\nhello\r\n0\r\n\r\n",
                                      headers=["Transfer-Encoding: chunked"], length=False), 400, "-",
    "a chunk size that is not hex (libmicrohttpd)")
raw("hdr-chunk-size-huge", request("POST", "/v1/render", b"FFFFFFFFFFFFFFFFFF\r\nhello\r\n0\r\n\r\n",
                                   headers=["Transfer-Encoding: chunked"], length=False), 413, "-",
    "a chunk size over 64 bits (libmicrohttpd)")
raw("hdr-chunked-truncated", request("POST", "/v1/render", b"100\r\n{\"camera\"",
                                     headers=["Transfer-Encoding: chunked"], length=False),
    "close", "-", "a chunked body cut off, client half-closes", shut=True)
raw("hdr-length-truncated", request("POST", "/v1/render", GOOD[:20],
                                    headers=["Content-Length: %d" % len(GOOD)], length=False),
    "close", "-", "a body shorter than its Content-Length, client half-closes", shut=True)
raw("hdr-auth-missing", request("POST", "/v1/render", GOOD, auth=False), 401, "unauthorized",
    "no Authorization header")
for name, value in [("hdr-auth-basic", "Basic dXNlcjpwYXNz"), ("hdr-auth-bearer-empty", "Bearer"),
                    ("hdr-auth-bearer-space", "Bearer "), ("hdr-auth-wrong-token", "Bearer wrong"),
                    ("hdr-auth-token-prefix", "Bearer " + TOKEN[:-1]),
                    ("hdr-auth-token-suffix", "Bearer " + TOKEN + "x"),
                    ("hdr-auth-token-nul", "Bearer " + TOKEN[:4]),
                    ("hdr-auth-no-scheme", TOKEN), ("hdr-auth-long", "Bearer " + "x" * 8000)]:
    raw(name, request("POST", "/v1/render", GOOD, auth=False, headers=["Authorization: " + value]),
        401, "unauthorized", "Authorization: %s" % value[:30])
raw("hdr-auth-twice-wrong-first", request("POST", "/v1/render", GOOD, auth=False,
                                          headers=["Authorization: Bearer wrong", AUTH.strip()]),
    401, "unauthorized", "two Authorization headers, the first wrong")
raw("hdr-auth-on-metrics", request("GET", "/metrics", auth=False), 401, "unauthorized",
    "GET /metrics without the token")
raw("hdr-http-2", request("GET", "/healthz", version="HTTP/2.0"), 505, "-",
    "HTTP/2.0 on a plain request line (libmicrohttpd)")
raw("hdr-http-3", request("GET", "/healthz", version="HTTP/3.0"), 505, "-",
    "HTTP/3.0 (libmicrohttpd)")
raw("hdr-http-0-9", b"GET /healthz\r\n\r\n", 400, "-",
    "an HTTP/0.9 request line (libmicrohttpd)")
raw("hdr-no-host", b"GET /healthz HTTP/1.1\r\n" + AUTH.encode() + b"Connection: close\r\n\r\n", 400,
    "bad_request", "HTTP/1.1 without Host")
raw("hdr-no-colon", request("GET", "/healthz", headers=["NoColonHere"]), 400, "-",
    "a header line without a colon (libmicrohttpd)")
raw("hdr-garbage-request-line", b"\x00\xff\xfe garbage\r\n\r\n", "close", "-",
    "binary garbage as the request line (libmicrohttpd closes)")
raw("hdr-space-in-target", request("GET", "/health z"), 400, "bad_request",
    "a space inside the request target")

if __name__ == "__main__":
    shutil.rmtree(OUT, ignore_errors=True)
    os.makedirs(OUT)
    with open(os.path.join(HERE, "manifest.tsv"), "w") as m:
        m.write("# name\tstatus\tcode\tshut\twhat  (generated by make_requests.py)\n")
        for name, data, status, code, shut, what in CASES:
            with open(os.path.join(OUT, name + ".http"), "wb") as f:
                f.write(data)
            m.write("%s\t%s\t%s\t%s\t%s\n" % (name, status, code, shut, what.replace("\t", " ")))
    print("%d cases, %d bytes" % (len(CASES), sum(len(c[1]) for c in CASES)))
