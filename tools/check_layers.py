#!/usr/bin/env python3
"""check_layers.py -- the build keeps rayd's layers one way and without circles.

rayd is built in layers (docs/architecture.md), a folder each: the core's
folders from core/base/ up to core/load/, then the programs (programs/render/,
programs/client/, server/) on top of the core's public header
include/rayd/rayd.h, and inside server/ its own folders from server/base/ up
to server/net/ and main.c.  A file may use its own layer and the layers
below it, never one above; and no group of files may use each other in a
circle, even inside one layer.  The tables below name folders, not files;
only the work layer's files keep an order of their own (FOLDER_ORDER).

Two kinds of use are read, and both must obey:
  - includes: every `#include "..."` of every .c and .h, by grep;
  - calls and data: every undefined symbol of every object file, matched
    with the object that defines it, by `nm`, so a call through a header
    that was not included, or an `extern` written by hand, is seen too.
And in the core, where each header is the interface of its own folder, a
header may name only functions of its own and lower layers: a low header
that declares a function a higher layer defines hands every includer a
call up, which neither kind of use shows until some file makes the call.
(server/'s shared headers, api.h and request.h, declare the layers above
them on purpose: they are those layers' interfaces.)

A circle is a set of files that use each other: .c files whose functions
call each other round, or headers that include each other round.  A header
is an interface: a file that takes types from scene.h does not depend on
scene.c, so a dispatcher (shape.c) may call the files that include its
header (shape_box.c); only a call back would close a circle.  The programs may
reach the core only through include/rayd/: no include of a core header, and
no core symbol that is not a rayd_ name of the public header.

Every core/ and server/ file lies in a layer's folder; a library's header
(<microhttpd.h>, <cjson/cJSON.h>, <png.h>, <openexr.h>, <curl/curl.h>, ...)
is included only in the folders SYSTEM_HEADERS gives it; and the diagrams
of docs/architecture.md are the ones these tables make.

The programs are folders side by side (PROGRAMS): each uses its own folder
and the rooms the table lists for it, nothing of another program.  Their
shared room, programs/common/, is used by rayd-render and rayd-client alone
and uses nothing but include/rayd/rayd.h and the C library: its system
headers are checked against the C and POSIX headers (LIBC_HEADERS), so
libcurl, cJSON or libpng cannot slip into it.

Usage: check_layers.py BUILD [ROOT]   (ROOT defaults to the current folder)
Prints "PASS name" or "FAIL name: why" lines, as the tests do, and exits 1
when any check fails.  `--self-test` builds small trees that break each rule
and checks that every break is reported.  `--docs` prints the diagrams,
`--write-docs [ROOT]` puts them into ROOT's docs/architecture.md.
"""
import concurrent.futures
import os
import re
import shutil
import subprocess
import sys
import tempfile
import textwrap

# The layers, bottom to top: (folder, what it holds).  A file belongs to the
# layer of the folder it is in; a folder is one floor, so the layer rule
# reads as folder prefixes.  docs/architecture.md's layer diagrams are made
# from these tables (--docs prints them, --write-docs puts them in place) and
# `run` fails when the page and the tables differ.
CORE_LAYERS = [
    ("core/base/", "error (status, message, JSON Pointer, line/column), array, hugemem, parallel, "
                   "clock, bytes (little-endian words), cpu (whether the AVX-512 and AVX2 code runs), meter (a render thread's ray count, "
                   "cancel flag and ray budget), share (what scenes of the same bytes share)"),
    ("core/math/", "vec.h, xform, poly (the quadratic and the quartic), rng.h, turn.h (the "
                   "samplers' sin and cos of 2 pi u), roulette.h (the path tracer's Russian "
                   "roulette), keyframe (interpolation of animation keys, "
                   "quaternion slerp)"),
    ("core/format/", "byte-level formats on base and math alone: json_check, json_parse (the "
                     "locked cJSON parse), json_numbers, json_pointer, base64, mesh_io + "
                     "mesh_obj, mesh_ply, mesh_gltf (with its animation channels), hdr_scan, "
                     "deflate_chain, file, text_encoding (naming UTF-16 and UTF-32 text)"),
    ("core/accel/", "bvh.c (the SAH builder and walk, over boxes), bvh16.h (16-ray packet walk, "
                    "AVX-512), bvh_rays8.h (8-ray packet walk, AVX2), light_buffer.c (which objects can shadow which directions of a point light)"),
    ("core/geom/", "shape.c + shape_*.c (one file per primitive), mesh.c + mesh_packet.c "
                   "+ mesh_packet8.c (one ray, 16 rays, 8 rays with AVX2; the one-ray walk all "
                   "use in mesh_walk.h), mesh_share.c (built "
                   "meshes the scenes of the same source share), camera"),
    ("core/shade/", "material, light, texture, environment: what surfaces and lights are; "
                    "texels.c (decoded images the scenes of the same bytes share)"),
    ("core/scene/", "scene.c (the frozen scene), scene_query.c (one ray: hits, CSG, shadows, "
                    "surfaces), scene_packet.c (16 rays at once), scene_packet8.c (the same as two "
                    "packets of 8, AVX2), scene_leave.c (which objects a "
                    "ray leaving them cannot meet again)"),
    ("core/render/", "render.c (regions, tiles, threads; exact per-pixel sums), accum.c "
                     "(progressive passes and sample ranges), aov.c (AOVs: what each camera ray "
                     "hits), denoise.c + accum_denoise.c (the a-trous denoiser and its "
                     "apron'd accumulator), srgb.c, integrate*.c (Whitted, path, 16-wide), image"),
    ("core/codec/", "image codecs on render/image.h: png.c (decode, 16-bit encode) + png_encode.c "
                    "(parallel bands), exr.c + exr_read.c (EXR out and in, one channel table in exr_chans.h; exr_imf.cc: DWA and tiled maps through the C++ library), sums.c (a sample "
                    "range's exact sums as bytes)"),
    ("core/load/", "the scene loader: scene_json*.c (scene_json.c the entry point), "
                   "gltf_material.c (glTF materials and images as rayd's)"),
]
SERVER_LAYERS = [
    ("server/base/", "base.h: config.c, log.c, clock.c, mem.c (the memory budget), metrics.c "
                     "(+ procstat.c), blob.c (a shared PNG), json.c, video.c (ffmpeg)"),
    ("server/work/", "work.h for the layers above, work_private.h for the work files alone; "
                     "work.c (the one lock), the caches, scenes, costs, tasks, the job store "
                     "(SQLite, store.c), jobs, events, the watcher, the scheduler, the scene "
                     "compiles, frame-range jobs (shots.c), the restart of stored jobs "
                     "(durable.c)"),
    ("server/cluster/", "cluster.h: rayd --redis, jobs shared by the nodes through Redis: redis.c "
                        "(the connection), cluster_state.c (names, counters, the view), "
                        "cluster_items.c (the item streams, one per priority), "
                        "cluster_jobs.c (the records), cluster_assemble.c (tiles in, frames "
                        "out), cluster_video.c (a frame range's video), cluster_node.c (the "
                        "puller), cluster.c (start, the request "
                        "thread, /metrics)"),
    ("server/req/", "request.h: http_req.c (headers, query, suspend/resume, counts), "
                    "http_reply.c (replies, the error body)"),
    ("server/api/", "api.h: the handlers, a file per resource (api_render.c, api_jobs.c + "
                    "api_jobs_image.c + api_jobs_json.c, api_shots.c (frame-range jobs), "
                    "api_events.c, api_cluster*.c (rayd --redis), api_health.c, api_web.c, "
                    "api_test.c); api.c (region, JSON check, the one status -> HTTP mapping, "
                    "body -> scene), api_cost.c (who asks; a render's price and budgets) and "
                    "api_sse.c (an event stream's text) shared by them"),
    ("server/route/", "router.h: router.c (the route table; which paths are open without a "
                      "token)"),
    ("server/net/", "transport.h: http.c (libmicrohttpd: the daemon, TLS, options) and "
                    "http_flow.c (limits, framing, auth, CORS preflight, access log), "
                    "http_deadline.c (the deadline for the headers)"),
    ("server/main.c", "starts and stops the layers (sched_start, router_start, http_start; "
                      "drain)"),
]
# Inside a folder the files may be ordered too: each calls only those in its
# own group or an earlier one.  The work layer's files, in call order (by
# file name without .c/.h):
FOLDER_ORDER = {
    "server/work/": [
        ["work", "work_private"], ["lru"], ["cache", "rcache"], ["scenefiles"], ["scenes"],
        ["cost"], ["fair"], ["resolve"], ["passes"], ["task"], ["budget"], ["gate"], ["store_file"], ["store", "store_dir"],
        ["jobs"], ["events"], ["videoq"], ["watch"], ["sched"], ["compile"],
        ["shots", "shots_private", "shots_events", "shots_info"], ["durable"],
    ],
}
# Programs above the core, side by side: each folder, and the rooms besides
# its own that it may use (and link).  Anything else of programs/ or server/
# is another program's.  Keep in step with docs/architecture.md.
PROGRAMS = {
    "programs/render/": ["programs/common/"],   # rayd-render
    "programs/client/": ["programs/common/"],   # rayd-client
    "programs/common/": [],                     # their shared room (lauxlib-style)
    "server/": [],                              # rayd (its own option parser)
}
COMMON = "programs/common/"
PUBLIC = "include/rayd/"
# The system headers the common room may include: the C library's (C11 and
# POSIX), nothing that needs a library of its own.
LIBC_HEADERS = set("""
    assert.h complex.h ctype.h errno.h fenv.h float.h inttypes.h iso646.h limits.h locale.h
    math.h setjmp.h signal.h stdalign.h stdarg.h stdatomic.h stdbool.h stddef.h stdint.h
    stdio.h stdlib.h stdnoreturn.h string.h tgmath.h threads.h time.h uchar.h wchar.h wctype.h
    dirent.h fcntl.h fnmatch.h getopt.h glob.h libgen.h poll.h pthread.h regex.h sched.h
    strings.h sys/mman.h sys/resource.h sys/select.h sys/stat.h sys/statvfs.h sys/time.h
    sys/types.h sys/uio.h sys/wait.h termios.h unistd.h utime.h
""".split())

# System headers and the folders (or files) that may include them: each
# library has a room.
MHD_ROOMS = ["server/net/"]
SYSTEM_HEADERS = [
    ("microhttpd.h", "libmicrohttpd", MHD_ROOMS),
    ("sqlite3.h", "SQLite", ["server/work/store.c"]),
    ("hiredis/hiredis.h", "hiredis", ["server/cluster/"]),
    ("cjson/cJSON.h", "cJSON", ["core/format/", "core/load/", "server/base/", "server/req/",
                                "server/cluster/", "server/api/", "programs/client/"]),
    ("png.h", "libpng", ["core/codec/"]),
    ("openexr.h", "OpenEXR", ["core/codec/"]),
    ("zlib.h", "zlib", ["core/codec/"]),
    ("libdeflate.h", "libdeflate", ["core/codec/"]),
    ("isa-l.h", "ISA-L", ["core/codec/"]),
    ("stb/stb_image.h", "stb_image", ["core/load/"]),
    ("curl/curl.h", "libcurl", ["programs/client/"]),
]

INCLUDE_RE = re.compile(r'^\s*#\s*include\s+[<"]([^">]+)[">]', re.M)


def rank_of(path, layers):
    """(rank, name) of the layer that owns path, or (None, None).  A rank is
    (the folder's place, the file's group in FOLDER_ORDER); a file in an
    ordered folder that its order does not list belongs to no layer."""
    for i, (folder, _) in enumerate(layers):
        if path == folder or path.startswith(folder):
            order = FOLDER_ORDER.get(folder)
            if order is None:
                return (i, 0), folder.rstrip("/")
            stem = os.path.splitext(os.path.basename(path))[0]
            for j, group in enumerate(order):
                if stem in group:
                    return (i, j), folder.rstrip("/") + ": " + group[0]
            return None, None
    return None, None


def source_files(root):
    out = []
    for top in ["core", "server", "programs"]:
        for dirpath, _, names in os.walk(os.path.join(root, top)):
            if "/web" in dirpath:
                continue
            for n in sorted(names):
                if n.endswith((".c", ".h")):
                    out.append(os.path.relpath(os.path.join(dirpath, n), root))
    return sorted(out)


def resolve_include(root, src, inc):
    """The repository path an include names, or None for system headers."""
    cands = [os.path.join(os.path.dirname(src), inc)]
    if src.startswith("server/"):
        cands.append(os.path.join("server", inc))  # built with -Iserver
    cands += [os.path.join("core", inc), os.path.join("include", inc),
              os.path.join("programs", inc)]
    for c in cands:
        c = os.path.normpath(c)
        if os.path.isfile(os.path.join(root, c)):
            return c
    return None


class Report:
    def __init__(self):
        self.failed = 0

    def check(self, name, problems):
        if problems:
            self.failed += 1
            shown = problems[:20]
            more = f" (and {len(problems) - 20} more)" if len(problems) > 20 else ""
            print(f"FAIL {name}: " + "; ".join(shown) + more)
        else:
            print(f"PASS {name}")


def include_edges(root, files):
    edges = []  # (from file, to file)
    for f in files:
        with open(os.path.join(root, f), encoding="utf-8", errors="replace") as fh:
            text = fh.read()
        for inc in INCLUDE_RE.findall(text):
            to = resolve_include(root, f, inc)
            if to:
                edges.append((f, to))
    return edges


def nm_symbols(objs):
    """{object: (defined, undefined) global symbols}, from one run of nm
    (one run per object cost 0.1 s each, most of this check's time)."""
    out = {o: (set(), set()) for o in objs}
    if not objs:
        return out
    text = subprocess.run(["nm", "-A"] + objs, capture_output=True, text=True, check=True).stdout
    for line in text.splitlines():
        obj, _, rest = line.partition(":")  # nm -A: "file.o:addr type name"
        parts = rest.split()
        if obj not in out:
            continue
        if len(parts) == 2 and parts[0] == "U":
            out[obj][1].add(parts[1])
        elif len(parts) == 3 and parts[1] in "TDBRCGSV":
            out[obj][0].add(parts[2])
    return out


def symbol_edges(root, build, files):
    """(from source, to source) for every symbol one object takes from another."""
    paths = {}
    for f in files:
        if f.endswith(".c"):
            o = os.path.join(build, os.path.splitext(f)[0] + ".o")
            if os.path.isfile(o):
                paths[f] = o
    syms = nm_symbols(list(paths.values()))
    objs = {f: syms[o] for f, o in paths.items()}
    definer = {}
    for f, (defined, _) in objs.items():
        for s in defined:
            definer.setdefault(s, []).append(f)
    edges = []
    for f, (_, undefined) in objs.items():
        for s in undefined:
            ds = definer.get(s, [])
            # A program's own definition wins at its link; else one in a
            # folder it may be linked with: the core, the common room, and
            # for the common room the programs that link it.  Programs are
            # linked apart otherwise: the client never links server/, so a
            # name both define is no use of one by the other.
            own = [d for d in ds if same_program(f, d)]
            for d in own or [d for d in ds if linked_with(f, d)]:
                edges.append((f, d, s))
    return edges, objs


def program_of(path):
    for p in PROGRAMS:
        if path.startswith(p):
            return p
    return "core/" if path.startswith("core/") else None


def linked_with(a, b):
    """Whether b may be in the same link as a, besides a's own folder."""
    pa, pb = program_of(a), program_of(b)
    return pb in ("core/", COMMON) or (pa == COMMON and COMMON in PROGRAMS.get(pb, []))


def same_program(a, b):
    return program_of(a) == program_of(b)


def system_includes(root, files):
    """(file, system header) for every <...> include that is not a file of the tree."""
    out = []
    for f in files:
        with open(os.path.join(root, f), encoding="utf-8", errors="replace") as fh:
            text = fh.read()
        for m in re.finditer(r'^\s*#\s*include\s+<([^>]+)>', text, re.M):
            out.append((f, m.group(1)))
    return out


def system_header_problems(sys_incs):
    """Each library's header only in the rooms SYSTEM_HEADERS gives it."""
    problems = []
    for f, hdr in sys_incs:
        for name, lib, rooms in SYSTEM_HEADERS:
            if hdr == name and not any(f == r or f.startswith(r) for r in rooms):
                problems.append(f"{f} includes <{hdr}>: {lib} belongs only in "
                                + ", ".join(rooms))
    return sorted(set(problems))


def unplaced_problems(files, layers, scope):
    """Files under scope that no layer owns."""
    return [f"{f} belongs to no layer (add its folder, or its name to FOLDER_ORDER, "
            "in tools/check_layers.py)"
            for f in files if f.startswith(scope) and rank_of(f, layers)[0] is None]


def layer_problems(edges, layers, scope):
    problems = []
    for e in edges:
        a, b = e[0], e[1]
        if not (a.startswith(scope) and b.startswith(scope)):
            continue
        ra, na = rank_of(a, layers)
        rb, nb = rank_of(b, layers)
        if ra is None:
            problems.append(f"{a} belongs to no layer (add it to tools/check_layers.py)")
            continue
        if rb is not None and rb > ra:
            how = f"calls {e[2]}" if len(e) > 2 else "includes"
            problems.append(f"{a} ({na}) {how} {b} ({nb}), a higher layer")
    return sorted(set(problems))


def strip_comments(text):
    return re.sub(r"//[^\n]*", "", re.sub(r"/\*.*?\*/", " ", text, flags=re.S))


def header_problems(root, files, objs, layers, scope):
    """Headers that name a function defined in a layer above their own.

    Whoever includes such a header is handed a call up, and neither the
    includes nor the symbols show it until some lower file makes the call.
    """
    definer = {}
    for f, (defined, _) in objs.items():
        for s in defined:
            definer.setdefault(s, f)
    problems = []
    for h in files:
        if not (h.endswith(".h") and h.startswith(scope)):
            continue
        rh, nh = rank_of(h, layers)
        with open(os.path.join(root, h), encoding="utf-8", errors="replace") as fh:
            text = strip_comments(fh.read())
        for name in sorted(set(re.findall(r"\b([A-Za-z_]\w*)\s*\(", text))):
            d = definer.get(name)
            rd, nd = rank_of(d, layers) if d and d.startswith(scope) else (None, None)
            if rh is not None and rd is not None and rd > rh:
                problems.append(f"{h} ({nh}) names {name}, defined in {d} ({nd}), a higher layer")
    return sorted(set(problems))


def public_problems(inc_edges, sym_edges):
    problems = []
    for a, b in inc_edges:
        if program_of(a) in PROGRAMS and b.startswith("core/"):
            problems.append(f"{a} includes the core's private {b} (use {PUBLIC}rayd.h)")
    for a, b, s in sym_edges:
        if program_of(a) in PROGRAMS and b.startswith("core/") and not s.startswith("rayd_"):
            problems.append(f"{a} calls the core's private {s} ({b})")
    return sorted(set(problems))


def program_problems(edges):
    """Uses of a program's folder from outside the folders it may be used by."""
    problems = []
    for e in edges:
        a, b = e[0], e[1]
        pa, pb = program_of(a), program_of(b)
        if pb not in PROGRAMS or pa == pb:
            continue
        how = f"calls {e[2]} of" if len(e) > 2 else "includes"
        if pa in PROGRAMS and pb in PROGRAMS[pa]:
            continue
        if pa in PROGRAMS:
            may = ", ".join([pa] + PROGRAMS[pa])
            problems.append(f"{a} {how} {b}: {pa} may use only {may} and {PUBLIC}")
        else:
            problems.append(f"{a} {how} {b}: the core never uses a program")
    return sorted(set(problems))


def common_problems(root, files):
    """System headers of the common room that are not the C library's."""
    problems = []
    for f in files:
        if not f.startswith(COMMON):
            continue
        with open(os.path.join(root, f), encoding="utf-8", errors="replace") as fh:
            text = strip_comments(fh.read())
        for inc in INCLUDE_RE.findall(text):
            if resolve_include(root, f, inc) is None and inc not in LIBC_HEADERS:
                problems.append(f"{f} includes <{inc}>: {COMMON} uses only {PUBLIC}rayd.h "
                                "and the C library")
    return sorted(set(problems))


def circles(edges):
    """Groups of files that use each other in a circle (Tarjan's SCC)."""
    graph = {}
    for e in edges:
        a, b = e[0], e[1]
        if a != b:
            graph.setdefault(a, set()).add(b)
            graph.setdefault(b, set())
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        work = [(v, iter(sorted(graph[v])))]
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        while work:
            node, it = work[-1]
            nxt = next(it, None)
            if nxt is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == node:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
            elif nxt not in index:
                index[nxt] = low[nxt] = counter[0]
                counter[0] += 1
                stack.append(nxt)
                on.add(nxt)
                work.append((nxt, iter(sorted(graph[nxt]))))
            elif nxt in on:
                low[node] = min(low[node], index[nxt])

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


# ---- docs/architecture.md's diagrams, made from the tables ------------------

DOC = "docs/architecture.md"
WIDTH = 100


def libraries_of(folder):
    return [lib for _, lib, rooms in SYSTEM_HEADERS if folder in rooms]


def floor_lines(name, col, texts):
    """One floor of a diagram: its name, then its texts wrapped beside it."""
    out = []
    for t in texts:
        for line in textwrap.wrap(t, WIDTH - col - 1) or [""]:
            out.append(" " + (name if not out else "").ljust(col) + line)
    return out


def diagram(kind):
    """The layer diagram of "core" (with the programs on top) or "server"."""
    if kind == "core":
        top = [("programs", [", ".join(PROGRAMS) + ": each only through " + PUBLIC + "rayd.h "
                             "(opaque rayd_scene and rayd_image, rayd_ calls)"])]
        rows, bottom = CORE_LAYERS, []
    else:
        top, rows = [], SERVER_LAYERS
        bottom = [("core", [PUBLIC + "rayd.h only"])]
    floors = list(top)
    for folder, text in reversed(rows):
        texts = [text]
        order = FOLDER_ORDER.get(folder)
        if order:
            texts.append("in call order: " + " < ".join(", ".join(g) for g in order))
        libs = libraries_of(folder)
        if libs:
            texts.append("may include: " + ", ".join(libs))
        floors.append((folder, texts))
    floors += bottom
    col = max(len(n) for n, _ in floors) + 2
    lines = []
    for i, (name, texts) in enumerate(floors):
        if i:
            lines.append("   |")
        lines += floor_lines(name, col, texts)
    return "\n".join(lines) + "\n"


def doc_block(kind):
    return (f"<!-- check_layers: {kind} (made by tools/check_layers.py --write-docs "
            f"from its tables: edit those) -->\n```\n{diagram(kind)}```\n<!-- /check_layers -->")


BLOCK_RE = re.compile(r"<!-- check_layers: (\w+) .*?<!-- /check_layers -->", re.S)


def docs_problems(root):
    path = os.path.join(root, DOC)
    if not os.path.isfile(path):
        return [f"{DOC} is missing"]
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    found = {m.group(1): m.group(0) for m in BLOCK_RE.finditer(text)}
    problems = []
    for kind in ("core", "server"):
        if kind not in found:
            problems.append(f"{DOC} has no <!-- check_layers: {kind} --> diagram")
        elif found[kind] != doc_block(kind):
            problems.append(f"{DOC}'s {kind} diagram is not the tables' "
                            "(python3 tools/check_layers.py --write-docs)")
    return problems


def write_docs(root):
    path = os.path.join(root, DOC)
    with open(path, encoding="utf-8") as fh:
        text = fh.read()
    text = BLOCK_RE.sub(lambda m: doc_block(m.group(1)), text)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)


def run(build, root):
    files = source_files(root)
    inc = include_edges(root, files)
    sym, objs = symbol_edges(root, build, files)
    rep = Report()
    missing = [f for f in files if f.endswith(".c") and f not in objs]
    rep.check("layers: every source file has its object in " + build,
              [f"{f} has no object (build first)" for f in missing])
    rep.check("layers: core/ includes only its own and lower layers",
              layer_problems(inc, CORE_LAYERS, "core/"))
    rep.check("layers: core/ calls only its own and lower layers",
              layer_problems(sym, CORE_LAYERS, "core/"))
    rep.check("layers: core/ headers name only functions of their own and lower layers",
              header_problems(root, files, objs, CORE_LAYERS, "core/"))
    rep.check("layers: server/ includes only its own and lower layers",
              layer_problems(inc, SERVER_LAYERS, "server/"))
    rep.check("layers: server/ calls only its own and lower layers",
              layer_problems(sym, SERVER_LAYERS, "server/"))
    rep.check("layers: programs/ and server/ reach the core only through include/rayd/",
              public_problems(inc, sym))
    rep.check("layers: each program uses only its own folder and the rooms it lists "
              "(programs/common/ only by rayd-render and rayd-client)",
              program_problems(inc + sym))
    rep.check("layers: programs/common/ includes only include/rayd/rayd.h and libc headers",
              common_problems(root, files))
    rep.check("layers: no circle of includes or calls between files",
              ["circle: " + " <-> ".join(c) for c in circles(inc + sym)])
    rep.check("layers: every core/ and server/ file is in a layer",
              unplaced_problems(files, CORE_LAYERS, "core/")
              + unplaced_problems(files, SERVER_LAYERS, "server/"))
    sys_incs = system_includes(root, files)
    rep.check("layers: each library's header only in its room",
              system_header_problems(sys_incs))
    rep.check(f"layers: {DOC}'s diagrams are these tables", docs_problems(root))
    return rep.failed


# ---- self-test: each rule must catch its break ------------------------------

def write(root, path, text):
    full = os.path.join(root, path)
    os.makedirs(os.path.dirname(full), exist_ok=True)
    with open(full, "w", encoding="utf-8") as fh:
        fh.write(text)


def compile_tree(root, build, only=None):
    """Objects of root's .c files (of those in only, when given) into build."""
    for f in source_files(root):
        if f.endswith(".c") and (only is None or f in only):
            o = os.path.join(build, os.path.splitext(f)[0] + ".o")
            os.makedirs(os.path.dirname(o), exist_ok=True)
            top = "server" if f.startswith("server/") else "core"
            subprocess.run(["cc", "-c", "-I" + os.path.join(root, "include"),
                            "-I" + os.path.join(root, top), "-I" + os.path.join(root, "programs"),
                            os.path.join(root, f), "-o", o], check=True)


def self_test():
    """Trees with one break each; the run must fail the named check.  The sound
    tree is built once; each break is a copy of it with its files changed and
    compiled again (every file, when a header changed)."""
    base = {
        "include/rayd/rayd.h": "int rayd_api(void);\n",
        "core/base/b.h": "int b_fn(void);\n",
        "core/base/b.c": '#include "base/b.h"\nint b_fn(void) { return 1; }\n',
        "core/load/api.c": '#include "base/b.h"\n#include "rayd/rayd.h"\n'
                           "int rayd_api(void) { return b_fn(); }\n",
        "core/codec/p.h": "#include <png.h>\n",
        "server/base/base.h": "int s_base(void);\n",
        "server/base/s.c": '#include "base/base.h"\nint s_base(void) { return 1; }\n',
        "server/work/work.h": '#include "base/base.h"\nint s_work(void);\n',
        "server/work/lru.c": '#include "work/work.h"\nint s_work(void) { return s_base(); }\n',
        DOC: doc_block("core") + "\n" + doc_block("server") + "\n",
        "programs/common/common.h": "int c_fn(void);\n",
        "programs/common/c.c": '#include <stdio.h>\n#include "common/common.h"\n'
                               '#include "rayd/rayd.h"\nint c_fn(void) { return rayd_api(); }\n',
        "programs/render/main.c": '#include <rayd/rayd.h>\n#include "common/common.h"\n'
                                  "int main(void) { return rayd_api() + c_fn(); }\n",
        "programs/client/client.h": "int k_fn(void);\n",
        "programs/client/main.c": '#include "client.h"\n#include "common/common.h"\n'
                                  "int k_fn(void) { return 3; }\n"
                                  "int main(void) { return k_fn() + c_fn(); }\n",
        "server/main.c": '#include <rayd/rayd.h>\nint main(void) { return rayd_api(); }\n',
    }
    breaks = {
        "includes a higher layer": ("core/ includes", {
            "core/base/b.c": '#include "base/b.h"\n#include "load/x.h"\nint b_fn(void) { return 1; }\n',
            "core/load/x.h": "int x_fn(void);\n"}),
        "calls a higher layer": ("core/ calls", {
            "core/base/b.c": "int rayd_api(void);\nint b_fn(void) { return rayd_api(); }\n"}),
        "a circle inside one layer": ("no circle", {
            "core/base/c.h": "int c_fn(void);\n",
            "core/base/c.c": '#include "base/b.h"\nint c_fn(void) { return b_fn(); }\n',
            "core/base/b.c": '#include "base/b.h"\n#include "base/c.h"\n'
                             "int b_fn(void) { return c_fn() + 1; }\n"}),
        "a header names a function of a higher layer": ("core/ headers", {
            "core/base/b.h": "int b_fn(void);\nint x_fn(void);\n",
            "core/load/x.c": "int x_fn(void);\nint x_fn(void) { return 2; }\n"}),
        "a program includes a private header": ("through include/rayd/", {
            "programs/render/main.c": '#include "base/b.h"\nint main(void) { return b_fn(); }\n'}),
        "server/ includes a higher folder": ("server/ includes", {
            "server/base/s.c": '#include "base/base.h"\n#include "work/work.h"\n'
                               "int s_base(void) { return 1; }\n"}),
        "server/ calls a higher folder": ("server/ calls", {
            "server/base/s.c": "int s_net(void);\nint s_base(void) { return s_net(); }\n",
            "server/net/n.c": "int s_net(void);\nint s_net(void) { return 3; }\n"}),
        "a work file calls one after it": ("server/ calls", {
            "server/work/lru.c": "int s_work(void);\nint s_sched(void);\n"
                                 "int s_work(void) { return s_sched(); }\n",
            "server/work/sched.c": "int s_sched(void);\nint s_sched(void) { return 4; }\n"}),
        "a file in no layer's folder": ("in a layer", {
            "core/io/y.c": "int y_fn(void);\nint y_fn(void) { return 5; }\n"}),
        "a work file missing from the order": ("in a layer", {
            "server/work/new.h": "int s_new(void);\n"}),
        "a library outside its room": ("its room", {
            "core/base/j.h": "#include <cjson/cJSON.h>\n"}),
        "libmicrohttpd in a handler not allowed it": ("its room", {
            "server/api/api_x.c": "#include <microhttpd.h>\n"}),
        "the page's diagram differs from the tables": ("diagrams", {
            DOC: doc_block("core").replace("core/math/", "core/maths") + "\n"
                 + doc_block("server") + "\n"}),
        "the common room includes a program's header": ("uses only its own folder", {
            "programs/common/c.c": '#include "client/client.h"\nint c_fn(void) { return 1; }\n'}),
        "the common room calls a program": ("uses only its own folder", {
            "programs/common/c.c": "int k_fn(void);\nint c_fn(void) { return k_fn(); }\n"}),
        "the server includes the common room": ("uses only its own folder", {
            "server/main.c": '#include "common/common.h"\nint main(void) { return 0; }\n'}),
        "the server calls the common room": ("uses only its own folder", {
            "server/main.c": "int c_fn(void);\nint main(void) { return c_fn(); }\n"}),
        "one program uses another's file": ("uses only its own folder", {
            "programs/render/main.c": '#include "client/client.h"\n'
                                      "int main(void) { return k_fn(); }\n"}),
        "the common room includes a library's header": ("libc headers", {
            "programs/common/c.c": "#include <cjson/cJSON.h>\nint c_fn(void) { return 1; }\n"}),
    }
    failed = 0
    with tempfile.TemporaryDirectory() as top:
        sound = os.path.join(top, "sound")
        for p, t in base.items():
            write(sound, p, t)
        compile_tree(sound, os.path.join(sound, "build"))
        out = subprocess.run([sys.executable, __file__, os.path.join(sound, "build"), sound],
                             capture_output=True, text=True).stdout
        ok = "FAIL" not in out and out.count("PASS") >= 12
        print(("PASS" if ok else "FAIL") + " layers self-test: a sound tree passes"
              + ("" if ok else ": " + out.replace("\n", " | ")))
        failed += not ok
        # The breaks are independent trees: checked a few at once (each is
        # mostly compiler and nm processes), reported in their order.
        def one(i, what, expect, change):
            tmp = os.path.join(top, str(i))
            shutil.copytree(sound, tmp)
            for p, t in change.items():
                write(tmp, p, t)
            header = any(p.endswith(".h") for p in change)
            compile_tree(tmp, os.path.join(tmp, "build"), None if header else set(change))
            out = subprocess.run([sys.executable, __file__, os.path.join(tmp, "build"), tmp],
                                 capture_output=True, text=True).stdout
            fails = [l for l in out.splitlines() if l.startswith("FAIL")]
            ok = any(expect in l for l in fails)
            return ok, (("PASS" if ok else "FAIL") + f" layers self-test: {what} is caught"
                        + ("" if ok else f": got {fails or 'no FAIL'}"))
        with concurrent.futures.ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
            runs = [pool.submit(one, i, what, expect, change)
                    for i, (what, (expect, change)) in enumerate(breaks.items())]
            for r in runs:
                ok, line = r.result()
                print(line)
                failed += not ok
    return failed


def main():
    if sys.argv[1:] == ["--self-test"]:
        sys.exit(1 if self_test() else 0)
    if sys.argv[1:] == ["--docs"]:
        print(doc_block("core") + "\n\n" + doc_block("server"))
        return
    if sys.argv[1:2] == ["--write-docs"]:
        write_docs(sys.argv[2] if len(sys.argv) > 2 else ".")
        return
    if len(sys.argv) not in (2, 3):
        sys.exit("usage: check_layers.py BUILD [ROOT] | --self-test | --docs | --write-docs [ROOT]")
    build = sys.argv[1]
    root = sys.argv[2] if len(sys.argv) == 3 else "."
    sys.exit(1 if run(build, root) else 0)


if __name__ == "__main__":
    main()
