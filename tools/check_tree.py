#!/usr/bin/env python3
"""check_tree.py -- docs/architecture.md says what the tree is; files stay short.

usage: check_tree.py [ROOT] | --self-test

Three checks, each printing "PASS name" or "FAIL name: why" (as the tests
do); the exit status is 1 when any fails:

  - every path docs/architecture.md names exists.  A name is a word that
    ends in a source or document extension (`render.c`, `api.md`) or a
    `code span` with a slash in it (`core/geom/`, `base/error.c`).  A name
    with a slash is looked for from the root and from core/, server/ and
    include/ (the page writes `geom/x.c` for core/geom/x.c, as the includes
    do); a bare file name anywhere in the tree; `<kind>` and `*` match any
    part of a name.  URLs (`/v1/render`), options and build outputs
    (`build/...`) are not paths of the tree;
  - every folder of the tree down to two levels (`tests/`, `tests/unit/`)
    is described: the page names it with its slash;
  - no source file (.c .h .py .js .sh) is over MAX_LINES lines: past that a
    file is split by topic (the way test_mesh_obj.c and test_mesh_ply.c
    were).

The files of the tree are git's (git ls-files) when ROOT is a checkout, else
every file under ROOT but build/, node_modules/ and hidden folders.
`--self-test` builds small trees that break each check and checks that each
break is reported.
"""
import fnmatch
import os
import re
import subprocess
import sys
import tempfile

DOC = "docs/architecture.md"
MAX_LINES = 1000
SOURCE_EXT = (".c", ".h", ".py", ".js", ".sh")
# Extensions that make a bare word a file name on the page.
NAMED_EXT = ("c", "h", "cc", "py", "js", "sh", "md", "json", "map")
# Where a name with a slash may be rooted.
BASES = ["", "core/", "server/", "include/"]
# Names that are outputs of the build or of a run, not files of the tree.
NOT_TREE = ("build/", "$(BUILD)", "/")


def tree_files(root):
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-z"], capture_output=True,
                             check=True).stdout.decode()
        files = [f for f in out.split("\0") if f and os.path.exists(os.path.join(root, f))]
        if files:
            return sorted(files)
    except (OSError, subprocess.CalledProcessError):
        pass
    files = []
    for dirpath, dirs, names in os.walk(root):
        dirs[:] = [d for d in dirs if not d.startswith(".") and d not in ("build", "node_modules")]
        for n in names:
            files.append(os.path.relpath(os.path.join(dirpath, n), root))
    return sorted(files)


def folders(files, depth=2):
    out = set()
    for f in files:
        parts = f.split("/")[:-1]
        for i in range(1, min(len(parts), depth) + 1):
            out.add("/".join(parts[:i]) + "/")
    return sorted(out)


def names_on_page(text):
    """The paths a page names: code spans with a slash, words with a file extension."""
    names = set()
    for span in re.findall(r"`([^`\n]+)`", text):
        if "/" in span and " " not in span:
            names.add(span)
    word = r"(?<![\w/.<>*+-])([\w<>*+-][\w/.<>*+-]*\.(?:" + "|".join(NAMED_EXT) + r"))(?![\w/])"
    for m in re.finditer(word, text):
        names.add(m.group(1))
    return sorted(n for n in names if not n.startswith(NOT_TREE) and "://" not in n
                  and not n.startswith("-"))


def exists(name, files, dirs):
    pattern = re.sub(r"<[^>]*>", "*", name)
    if "/" not in pattern.rstrip("/"):
        if pattern.endswith("/"):
            return any(d.endswith("/" + pattern) or d == pattern for d in dirs)
        return any(fnmatch.fnmatch(os.path.basename(f), pattern) for f in files)
    for base in BASES:
        want = base + pattern
        if want.endswith("/"):
            if any(fnmatch.fnmatch(d, want) for d in dirs):
                return True
        elif any(fnmatch.fnmatch(f, want) for f in files):
            return True
    return False


def check(root):
    files = tree_files(root)
    all_dirs = folders(files, depth=99)
    failed = 0

    def report(name, problems):
        nonlocal failed
        if problems:
            failed += 1
            more = f" (and {len(problems) - 20} more)" if len(problems) > 20 else ""
            print(f"FAIL {name}: " + "; ".join(problems[:20]) + more)
        else:
            print(f"PASS {name}")

    path = os.path.join(root, DOC)
    text = open(path, encoding="utf-8").read() if os.path.isfile(path) else ""
    report(f"tree: {DOC} exists", [] if text else [f"no {DOC}"])
    report(f"tree: every path {DOC} names exists",
           [f"{n} is named but not in the tree" for n in names_on_page(text)
            if not exists(n, files, all_dirs)])
    report(f"tree: {DOC} describes every folder",
           [f"{d} is not on the page" for d in folders(files)
            if not re.search(r"(?<![\w/])" + re.escape(d), text)])
    long = []
    for f in files:
        if f.endswith(SOURCE_EXT):
            with open(os.path.join(root, f), encoding="utf-8", errors="replace") as fh:
                n = sum(1 for _ in fh)
            if n > MAX_LINES:
                long.append(f"{f} has {n} lines (split it by topic)")
    report(f"tree: no source file over {MAX_LINES} lines", long)
    return failed


def self_test():
    """Trees with one break each; the run must fail the named check."""
    base = {
        "core/geom/shape.c": "int x;\n",
        "tests/unit/test_shape.c": "int y;\n",
        DOC: "`core/` and `core/geom/` hold `shape.c` (see `geom/shape.c`, shape*.c);\n"
             "`tests/` and `tests/unit/` the tests; `docs/` this page, architecture.md.\n"
             "A route `/v1/render`, an output `build/rayd`.\n",
    }
    breaks = {
        "a named file that is not there": ("names exists", {
            DOC: base[DOC] + "And `core/geom/gone.c`.\n"}),
        "a named bare file that is not there": ("names exists", {
            DOC: base[DOC] + "And gone.h.\n"}),
        "a folder the page does not describe": ("every folder", {
            "core/shade/light.c": "int z;\n"}),
        "a source file too long": ("over", {
            "core/geom/shape.c": "int x;\n" * (MAX_LINES + 1)}),
    }
    failed = 0
    for what, (expect, change) in list(breaks.items()) + [("a sound tree passes", (None, {}))]:
        with tempfile.TemporaryDirectory() as tmp:
            for p, t in {**base, **change}.items():
                os.makedirs(os.path.dirname(os.path.join(tmp, p)), exist_ok=True)
                with open(os.path.join(tmp, p), "w", encoding="utf-8") as fh:
                    fh.write(t)
            out = subprocess.run([sys.executable, __file__, tmp], capture_output=True,
                                 text=True).stdout
            fails = [l for l in out.splitlines() if l.startswith("FAIL")]
            ok = (not fails and out.count("PASS") == 4) if expect is None else \
                any(expect in l for l in fails)
            name = what if expect is None else what + " is caught"
            print(("PASS" if ok else "FAIL") + f" tree self-test: {name}"
                  + ("" if ok else f": got {fails or out.strip() or 'no output'}"))
            failed += not ok
    return failed


def main():
    if sys.argv[1:] == ["--self-test"]:
        sys.exit(1 if self_test() else 0)
    if len(sys.argv) > 2:
        sys.exit("usage: check_tree.py [ROOT] | --self-test")
    sys.exit(1 if check(sys.argv[1] if len(sys.argv) == 2 else ".") else 0)


if __name__ == "__main__":
    main()
