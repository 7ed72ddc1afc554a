#!/usr/bin/env python3
"""unused_exports.py -- no exported function that nobody else calls.

A function without `static` is a promise that another file uses it.  When
the last caller goes, the function stays, compiled, linked and read by the
next newcomer; this check makes that visible.  It reads the build's objects
with `nm`, as tools/check_layers.py does: every global symbol an object of
the core or of a program defines (T, D, R, B) must be taken (U) by some
other object, or be named in the sources that are built without objects of
their own (tests/unit, tests/fuzz, tests/tools, bench: they include the
core's private headers and test its internals one by one).

Allowed without a caller, by rule or by name (ALLOWED below):
  - main and LLVMFuzzerTestOneInput, the entry points;
  - every name declared in include/rayd/ (the public API: its callers are
    programs outside this tree);
  - the explicit list ALLOWED, each with the reason it stays.

A symbol used only inside its own file is reported too: it should be
`static` (and leave its header).  Usage: unused_exports.py BUILD [ROOT]
prints "PASS name" or "FAIL name: why" lines; `--self-test` plants an
unused function in a small tree and checks that it is caught.
"""
import os
import re
import subprocess
import sys
import tempfile

# Folders whose objects are checked (whatever their subfolders).
CHECKED = ("core/", "server/", "cli/", "clients/", "programs/")
# Folders whose sources count as callers though the build makes no object
# of them (they are compiled straight into test and bench programs).
CALLER_SOURCES = ("tests/unit", "tests/fuzz", "tests/tools", "bench")
PUBLIC = "include/rayd"
ENTRY_POINTS = {"main", "LLVMFuzzerTestOneInput"}
# name: why it may stay exported with no caller in the tree.
ALLOWED = {
}

WORD_RE = re.compile(r"\b[A-Za-z_]\w*\b")


def nm_symbols(objs):
    """{object: (defined, undefined) global symbols}, from one run of nm."""
    out = {o: (set(), set()) for o in objs}
    if not objs:
        return out
    text = subprocess.run(["nm", "-A"] + objs, capture_output=True, text=True,
                          check=True).stdout
    for line in text.splitlines():
        obj, _, rest = line.partition(":")  # nm -A: "file.o:addr type name"
        parts = rest.split()
        if obj not in out:
            continue
        if len(parts) == 2 and parts[0] == "U":
            out[obj][1].add(parts[1])
        elif len(parts) == 3 and parts[1] in "TDBRCGSV":
            # ASan adds a "__odr_asan.NAME" marker beside each global
            # variable, and C++ (core/codec/exr_imf.cc) its "DW.ref."
            # exception-handling references and mangled "_Z" names: none
            # is one of our functions, and NAME itself is checked.
            if not parts[2].startswith(("__odr_asan", "DW.ref.", "_Z")):
                out[obj][0].add(parts[2])
    return out


def objects(build):
    """{source-relative object path: (defined, undefined)} of the checked folders.

    Only the plain build's objects: its asan/, tsan/, pic/ and fuzz/ copies
    are the same sources again.
    """
    paths = []
    for top in CHECKED:
        for dirpath, _, names in os.walk(os.path.join(build, top)):
            paths += [os.path.join(dirpath, n) for n in sorted(names) if n.endswith(".o")]
    return {os.path.relpath(p, build): syms for p, syms in nm_symbols(paths).items()}


def words_in(root, folders, exts=(".c", ".h", ".cc")):
    words = set()
    for folder in folders:
        for dirpath, _, names in os.walk(os.path.join(root, folder)):
            if "node_modules" in dirpath:
                continue
            for n in names:
                if n.endswith(exts):
                    with open(os.path.join(dirpath, n), encoding="utf-8", errors="replace") as fh:
                        words.update(WORD_RE.findall(fh.read()))
    return words


def unused(build, root):
    objs = objects(build)
    taken = {}
    for o, (_, undefined) in objs.items():
        for s in undefined:
            taken.setdefault(s, set()).add(o)
    callers = words_in(root, CALLER_SOURCES)
    public = words_in(root, [PUBLIC], (".h",))
    problems = []
    for o, (defined, _) in sorted(objs.items()):
        for s in sorted(defined):
            if s in ENTRY_POINTS or s in public or s in ALLOWED or s in callers:
                continue
            if taken.get(s, set()) - {o}:
                continue
            src = os.path.splitext(o)[0] + ".c"
            problems.append(f"{s} ({src}) has no caller outside its file: "
                            "make it static, or delete it")
    return objs, problems


def run(build, root):
    objs, problems = unused(build, root)
    failed = 0
    if not objs:
        print(f"FAIL exports: no objects under {build} (build first)")
        return 1
    if problems:
        print(f"FAIL exports: every exported function has a caller: {len(problems)} without: "
              + "; ".join(problems))
        failed += 1
    else:
        print(f"PASS exports: every exported function has a caller ({len(objs)} objects)")
    stale = sorted(s for s in ALLOWED if not any(s in d for d, _ in objs.values()))
    if stale:
        print("FAIL exports: the allowance list names only defined functions: "
              + ", ".join(stale) + " defined nowhere (remove from ALLOWED)")
        failed += 1
    else:
        print("PASS exports: the allowance list names only defined functions")
    return failed


# ---- self-test: a planted unused function must be caught --------------------

def write(root, path, text):
    full = os.path.join(root, path)
    os.makedirs(os.path.dirname(full), exist_ok=True)
    with open(full, "w", encoding="utf-8") as fh:
        fh.write(text)


def compile_tree(root, build):
    for dirpath, _, names in os.walk(root):
        for n in names:
            p = os.path.relpath(os.path.join(dirpath, n), root)
            if n.endswith(".c") and p.startswith(CHECKED):
                o = os.path.join(build, os.path.splitext(p)[0] + ".o")
                os.makedirs(os.path.dirname(o), exist_ok=True)
                subprocess.run(["cc", "-c", "-I" + os.path.join(root, "include"),
                                "-I" + os.path.join(root, "core"), os.path.join(root, p),
                                "-o", o], check=True)


def self_test():
    base = {
        "include/rayd/rayd.h": "int rayd_api(void);\n",
        "core/base/b.h": "int b_fn(void);\nint b_tested(void);\n",
        "core/base/b.c": "#include \"base/b.h\"\nint b_fn(void) { return 1; }\n"
                         "int b_tested(void) { return 2; }\n",
        "core/io/api.c": "#include \"base/b.h\"\n#include \"rayd/rayd.h\"\n"
                         "int rayd_api(void) { return b_fn(); }\n",
        "server/main.c": "#include <rayd/rayd.h>\nint main(void) { return rayd_api(); }\n",
        "tests/unit/test_b.c": "#include \"base/b.h\"\nint main(void) { return b_tested(); }\n",
    }
    breaks = {
        "a function nobody calls": ("dead_fn", {
            "server/log.c": "int dead_fn(void);\nint dead_fn(void) { return 3; }\n"}),
        "a function only its own file calls": ("own_fn", {
            "core/base/c.c": "int own_fn(void);\nint own_fn(void) { return 3; }\n"
                             "int c_user(void);\nint c_user(void) { return own_fn(); }\n",
            "server/main.c": "#include <rayd/rayd.h>\nint c_user(void);\n"
                             "int main(void) { return rayd_api() + c_user(); }\n"}),
    }
    failed = 0
    for what, (expect, change) in {**breaks, "a sound tree passes": (None, {})}.items():
        with tempfile.TemporaryDirectory() as tmp:
            for p, t in {**base, **change}.items():
                write(tmp, p, t)
            build = os.path.join(tmp, "build")
            compile_tree(tmp, build)
            out = subprocess.run([sys.executable, __file__, build, tmp], capture_output=True,
                                 text=True).stdout
            fails = [l for l in out.splitlines() if l.startswith("FAIL")]
            if expect is None:
                ok = not fails and out.count("PASS") == 2
            else:
                ok = any(expect in l for l in fails) and not any(
                    w in l for l in fails for w in ("b_fn", "b_tested", "rayd_api", "main ("))
            print(("PASS" if ok else "FAIL") + f" exports self-test: {what}"
                  + (" is caught" if expect else "")
                  + ("" if ok else ": got " + (" | ".join(fails) or out.strip() or "nothing")))
            failed += not ok
    return failed


def main():
    if sys.argv[1:] == ["--self-test"]:
        sys.exit(1 if self_test() else 0)
    if len(sys.argv) not in (2, 3):
        sys.exit("usage: unused_exports.py BUILD [ROOT] | --self-test")
    build = sys.argv[1]
    root = sys.argv[2] if len(sys.argv) == 3 else "."
    sys.exit(1 if run(build, root) else 0)


if __name__ == "__main__":
    main()
