#!/usr/bin/env python3
"""check_layers.py -- the build keeps rayd's layers one way and without circles.

rayd is built in layers (docs/architecture.md): the core's folders from
core/base up to core/io, then the programs (programs/render/, programs/client/,
server/) on top of the core's public header include/rayd/rayd.h, and inside
server/ its own layers from the base modules up to the transport.  A file may use its own
layer and the layers below it, never one above; and no group of files may
use each other in a circle, even inside one layer.

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

The programs are folders side by side (PROGRAMS): each uses its own folder
and the rooms the table lists for it, nothing of another program.  Their
shared room, programs/common/, is used by rayd-render and rayd-client alone
and uses nothing but include/rayd/rayd.h and the C library: its system
headers are checked against the C and POSIX headers (LIBC_HEADERS), so
libcurl, cJSON or libpng cannot slip into it.

Usage: check_layers.py BUILD [ROOT]   (ROOT defaults to the current folder)
Prints "PASS name" or "FAIL name: why" lines, as the tests do, and exits 1
when any check fails.  `--self-test` builds small trees that break each rule
and checks that every break is reported.
"""
import os
import re
import subprocess
import sys
import tempfile

# The layers, bottom to top.  A layer is a list of path prefixes or files;
# the first layer whose prefix matches a file owns it.  Keep this table in
# step with docs/architecture.md.
CORE_LAYERS = [
    ("core/base", ["core/base/"]),
    ("core/math", ["core/math/"]),
    ("core/accel", ["core/accel/"]),
    ("core/geom", ["core/geom/"]),
    ("core/shade", ["core/shade/"]),
    ("core/scene", ["core/scene/"]),
    ("core/render", ["core/render/"]),
    ("core/io", ["core/io/"]),
]
SERVER_LAYERS = [
    ("server/base", ["server/base.h", "server/config.", "server/log.", "server/clock.", "server/metrics.", "server/procstat.",
                     "server/blob.", "server/json.", "server/mem."]),
    # the work layer, its files in call order: each calls only those before it
    ("server/work: lock", ["server/work.h", "server/work_private.h", "server/work.c"]),
    ("server/work: lru", ["server/lru."]),
    ("server/work: caches", ["server/cache.", "server/rcache."]),
    ("server/work: scene files", ["server/scenefiles."]),
    ("server/work: scenes", ["server/scenes."]),
    ("server/work: cost", ["server/cost."]),
    ("server/work: fair", ["server/fair."]),
    ("server/work: resolve", ["server/resolve."]),
    ("server/work: passes", ["server/passes."]),
    ("server/work: task", ["server/task."]),
    ("server/work: budget", ["server/budget."]),
    ("server/work: gate", ["server/gate."]),
    ("server/work: jobs", ["server/jobs."]),
    ("server/work: events", ["server/events."]),
    ("server/work: watch", ["server/watch."]),
    ("server/work: sched", ["server/sched."]),
    ("server/work: compile", ["server/compile."]),
    ("server/request", ["server/request.h", "server/http_req."]),
    ("server/request: replies", ["server/http_reply."]),
    ("server/handlers: shared", ["server/api.h", "server/api.c", "server/api_cost."]),
    ("server/handlers", ["server/api_"]),
    ("server/router", ["server/router."]),
    ("server/transport: flow", ["server/transport.h", "server/http_flow."]),
    ("server/transport", ["server/http."]),
    ("server/main", ["server/main.c"]),
]
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

INCLUDE_RE = re.compile(r'^\s*#\s*include\s+[<"]([^">]+)[">]', re.M)


def rank_of(path, layers):
    for i, (name, prefixes) in enumerate(layers):
        if any(path == p or path.startswith(p) for p in prefixes):
            return i, name
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
    cands = [os.path.join(os.path.dirname(src), inc), os.path.join("core", inc),
             os.path.join("include", inc), os.path.join("programs", inc)]
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


def nm_symbols(obj):
    """(defined, undefined) global symbols of an object file."""
    out = subprocess.run(["nm", obj], capture_output=True, text=True, check=True).stdout
    defined, undefined = set(), set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] == "U":
            undefined.add(parts[1])
        elif len(parts) == 3 and parts[1] in "TDBRCGSV":
            defined.add(parts[2])
    return defined, undefined


def symbol_edges(root, build, files):
    """(from source, to source) for every symbol one object takes from another."""
    objs = {}
    for f in files:
        if f.endswith(".c"):
            o = os.path.join(build, os.path.splitext(f)[0] + ".o")
            if os.path.isfile(o):
                objs[f] = nm_symbols(o)
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
    return rep.failed


# ---- self-test: each rule must catch its break ------------------------------

def write(root, path, text):
    full = os.path.join(root, path)
    os.makedirs(os.path.dirname(full), exist_ok=True)
    with open(full, "w", encoding="utf-8") as fh:
        fh.write(text)


def compile_tree(root, build):
    for f in source_files(root):
        if f.endswith(".c"):
            o = os.path.join(build, os.path.splitext(f)[0] + ".o")
            os.makedirs(os.path.dirname(o), exist_ok=True)
            subprocess.run(["cc", "-c", "-I" + os.path.join(root, "include"),
                            "-I" + os.path.join(root, "core"), "-I" + os.path.join(root, "programs"),
                            os.path.join(root, f), "-o", o], check=True)


def self_test():
    """Trees with one break each; the run must fail exactly the named check."""
    base = {
        "include/rayd/rayd.h": "int rayd_api(void);\n",
        "core/base/b.h": "int b_fn(void);\n",
        "core/base/b.c": '#include "base/b.h"\nint b_fn(void) { return 1; }\n',
        "core/io/api.c": '#include "base/b.h"\n#include "rayd/rayd.h"\n'
                         "int rayd_api(void) { return b_fn(); }\n",
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
            "core/base/b.c": '#include "base/b.h"\n#include "io/x.h"\nint b_fn(void) { return 1; }\n',
            "core/io/x.h": "int x_fn(void);\n"}),
        "calls a higher layer": ("core/ calls", {
            "core/base/b.c": "int rayd_api(void);\nint b_fn(void) { return rayd_api(); }\n"}),
        "a circle inside one layer": ("no circle", {
            "core/base/c.h": "int c_fn(void);\n",
            "core/base/c.c": '#include "base/b.h"\nint c_fn(void) { return b_fn(); }\n',
            "core/base/b.c": '#include "base/b.h"\n#include "base/c.h"\n'
                             "int b_fn(void) { return c_fn() + 1; }\n"}),
        "a header names a function of a higher layer": ("core/ headers", {
            "core/base/b.h": "int b_fn(void);\nint x_fn(void);\n",
            "core/io/x.c": "int x_fn(void);\nint x_fn(void) { return 2; }\n"}),
        "a program includes a private header": ("through include/rayd/", {
            "programs/render/main.c": '#include "base/b.h"\nint main(void) { return b_fn(); }\n'}),
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
    for what, (expect, change) in breaks.items():
        with tempfile.TemporaryDirectory() as tmp:
            for p, t in {**base, **change}.items():
                write(tmp, p, t)
            build = os.path.join(tmp, "build")
            compile_tree(tmp, build)
            out = subprocess.run([sys.executable, __file__, build, tmp], capture_output=True,
                                 text=True).stdout
            fails = [l for l in out.splitlines() if l.startswith("FAIL")]
            ok = any(expect in l for l in fails)
            print(("PASS" if ok else "FAIL") + f" layers self-test: {what} is caught"
                  + ("" if ok else f": got {fails or 'no FAIL'}"))
            failed += not ok
    with tempfile.TemporaryDirectory() as tmp:
        for p, t in base.items():
            write(tmp, p, t)
        compile_tree(tmp, os.path.join(tmp, "build"))
        out = subprocess.run([sys.executable, __file__, os.path.join(tmp, "build"), tmp],
                             capture_output=True, text=True).stdout
        ok = "FAIL" not in out and out.count("PASS") >= 10
        print(("PASS" if ok else "FAIL") + " layers self-test: a sound tree passes"
              + ("" if ok else ": " + out.replace("\n", " | ")))
        failed += not ok
    return failed


def main():
    if sys.argv[1:] == ["--self-test"]:
        sys.exit(1 if self_test() else 0)
    if len(sys.argv) not in (2, 3):
        sys.exit("usage: check_layers.py BUILD [ROOT] | --self-test")
    build = sys.argv[1]
    root = sys.argv[2] if len(sys.argv) == 3 else "."
    sys.exit(1 if run(build, root) else 0)


if __name__ == "__main__":
    main()
