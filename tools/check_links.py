#!/usr/bin/env python3
"""check_links.py -- every link between the project's pages leads somewhere.

usage: check_links.py [ROOT] | --self-test

Every Markdown page git tracks (README.md, docs/*.md, bench/README.md ...)
is read for relative links, [text](path) and [text](path#anchor), outside
code blocks and code spans.  A link passes when its path exists (from the
page's own folder) and, when it names an anchor in a Markdown page, that
page has a heading whose GitHub anchor it is or an explicit
<a id="anchor"></a>.  Web addresses (http:, https:, mailto:) are not
followed.  Prints "PASS links" or one "FAIL links: PAGE:LINE: why" line per
broken link (as the tests do); the exit status is 1 when any is broken.

GitHub's anchor of a heading: its text without Markdown marks (code
backticks, emphasis, a link's address), lower-cased, every character but
letters, digits, spaces, hyphens and underscores dropped, each space a
hyphen; a repeated anchor gets -1, -2 ... in page order.
`--self-test` builds a small tree with a broken path, a broken anchor and
links that must pass, and checks that exactly the broken ones are reported.
"""
import os
import re
import sys
import tempfile

from check_tree import tree_files

LINK = re.compile(r"\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
EXPLICIT = re.compile(r"<a\s+(?:id|name)=\"([^\"]+)\"")
FENCE = re.compile(r"^\s*(```|~~~)")


def pages(root):
    return [f for f in tree_files(root) if f.endswith(".md")]


def prose_lines(text):
    """(line number, line) of the lines outside fenced code blocks."""
    inside = False
    for no, line in enumerate(text.split("\n"), 1):
        if FENCE.match(line):
            inside = not inside
            continue
        if not inside:
            yield no, line


def page_links(text):
    """(line number, target) of every link in the page's prose; a link's
    text may run over lines, as a wrapped paragraph has it."""
    lines = [""] * len(text.split("\n"))
    for no, line in prose_lines(text):
        lines[no - 1] = re.sub(r"`[^`]*`", lambda m: " " * len(m.group(0)), line)
    prose = "\n".join(lines)
    for m in LINK.finditer(prose):
        yield prose.count("\n", 0, m.start(1)) + 1, m.group(1)


def slug(heading):
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link: its text
    text = text.replace("`", "").replace("*", "")
    text = re.sub(r"(^|\s)_+|_+(\s|$)", r"\1\2", text)  # emphasis, not snake_case
    text = re.sub(r"<[^>]+>", "", text).lower()
    text = "".join(c for c in text if c.isalnum() or c in " -_")
    return text.replace(" ", "-")


def anchors(text):
    found, seen = set(), {}
    for _, line in prose_lines(text):
        found.update(EXPLICIT.findall(line))
        m = HEADING.match(line)
        if not m:
            continue
        base = slug(m.group(2))
        n = seen.get(base, 0)
        seen[base] = n + 1
        found.add(base if n == 0 else "%s-%d" % (base, n))
    return found


def broken_links(root):
    """(page, line, why) of every broken link under root."""
    cache, bad = {}, []

    def anchors_of(path):
        if path not in cache:
            with open(path, encoding="utf-8") as f:
                cache[path] = anchors(f.read())
        return cache[path]

    for page in pages(root):
        with open(os.path.join(root, page), encoding="utf-8") as f:
            text = f.read()
        for no, target in page_links(text):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            full = os.path.normpath(os.path.join(root, os.path.dirname(page), path)) \
                if path else os.path.join(root, page)
            if not os.path.exists(full):
                bad.append((page, no, "%s: no such file" % target))
            elif anchor and full.endswith(".md") and anchor not in anchors_of(full):
                bad.append((page, no, "%s: no heading or <a id> with that anchor" % target))
    return bad


def report(root):
    bad = broken_links(root)
    for page, no, why in bad:
        print("FAIL links: %s:%d: %s" % (page, no, why))
    if not bad:
        print("PASS links")
    return 1 if bad else 0


def self_test():
    files = {
        "README.md": "# Top\n\n## The `make run` target\n\n[a](docs/a.md#files-here) "
                     "[b](#the-make-run-target) [c](docs/a.md#gone) [d](missing.md)\n"
                     "`[e](nowhere.md)` [f](https://example.com/x#y)\n\n```sh\n[g](no.md)\n```\n",
        "docs/a.md": "# A\n\n<a id=\"files-here\"></a>\n**Files here.** [h](../README.md#top)\n"
                     "## Same\n## Same\n[i](#same-1) [j](#same-2) [a wrapped\nlink](#nowhere)\n",
    }
    want = {("README.md", 5, "docs/a.md#gone"), ("README.md", 5, "missing.md"),
            ("docs/a.md", 7, "#same-2"), ("docs/a.md", 8, "#nowhere")}
    with tempfile.TemporaryDirectory() as root:
        for name, text in files.items():
            os.makedirs(os.path.join(root, os.path.dirname(name)), exist_ok=True)
            with open(os.path.join(root, name), "w", encoding="utf-8") as f:
                f.write(text)
        got = {(p, n, why.split(":")[0]) for p, n, why in broken_links(root)}
    if got != want:
        print("FAIL links self-test: reported %s, expected %s" % (sorted(got), sorted(want)))
        return 1
    print("PASS links self-test")
    return 0


def main():
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..")
    return report(os.path.abspath(root))


if __name__ == "__main__":
    sys.exit(main())
