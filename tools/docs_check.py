#!/usr/bin/env python3
"""docs_check.py -- runs the examples of README.md and docs/*.md as a reader
pastes them, and compares their answers with what the docs say, so the docs
cannot drift from rayd.

    python3 tools/docs_check.py BUILD FILE.md...
    python3 tools/docs_check.py BUILD --self-test   (each rule fails a block that breaks it)

Every command block runs: a fenced block tagged sh, bash, shell or console,
or a block of "$ " lines.  Each page's blocks are pasted in order into one
bash of its own, at the root of a fresh copy of the repository (the files
git tracks, BUILD linked in as build/), with a rayd started as `make run`
starts it (tools/docs_paste.py says how, and what fails a block: a command's
nonzero exit, a traceback, "command not found", an HTTP status of 400 or
more, a JSON body saved under an image's name, a file named that does not
exist, a block still running after a minute).  Other blocks (output, JSON,
text) are not run unless marked.

A marker is an HTML comment that starts with "<!-- docs-check" just before
a fenced block (blank lines between are allowed).  It is invisible on
GitHub; its first line names a mode and options, its other lines (up to
"-->") are the mode's inputs:

  <!-- docs-check skip: WHY -->  the block is not run, and WHY is printed
      with the list of blocks not run: keep it for what the test cannot have
      (a cluster, docker, root, the whole test suite).
  <!-- docs-check -->            (mode "shell") the block's output is checked
      too: in a block of "$ " lines each command (with "\" continuations)
      runs in turn, and the lines after it, up to the next "$ ", are its
      expected output (stdout and stderr); the HTTP statuses are then not
      checked, the output shows them.  Option "exit=N": each command (a
      block without "$ ": its last) must exit N instead of 0, and a failing
      command in it is no failure (a documented failure).
  <!-- docs-check scene -->      the block is a whole scene: rayd-render must
      render it (exit 0).
  <!-- docs-check errors         each further comment line is a scene (or
      @FILE); the block's lines are, in order, what rayd-render prints for
      it (exit 1), and the server's JSON error must carry the same message
      and JSON Pointer (or line and column); with the option "cli-only"
      (the server's limits differ) only rayd-render is asked.  A scene line that starts with
      '"' is a JSON string holding the text (for newlines: "{\n ...").
  <!-- docs-check http           each further comment line is a request,
      "METHOD TARGET [BODY]" (BODY: JSON text, sent as application/json, or
      a JSON string holding the text);
      the block's lines are, in order, the JSON bodies of the answers, and
      an error's "status" is the HTTP status.

Expected output is compared line by line: "..." or "…" stands for any text;
with the option "any-numbers" every number stands for any number; with
"any=WORD" every WORD stands for any run of letters and digits (a random
job id).  Expected output that starts with "HTTP/" is an answer of
`curl -i`: its status code must match, each header shown must be there with
that value (others are ignored), then the body.  A JSON body or JSON line
matches when every key shown is there with a matching value (keys not shown
are ignored); arrays must have the same length.  "127.0.0.1:8080" and
"localhost:8080" (and other ports from 8000 to 8999) become the address of
the server the page runs against, in the block and in its expected output.

The scene, errors and http examples each talk to a rayd of their own,
started on 127.0.0.1 --port 0 with --threads 2 (the same answers on any
machine) and --asset-dir a scratch folder.  Each block prints one line,
"PASS docs:FILE:LINE (S s)", "FAIL docs:FILE:LINE: why (S s)" or
"SKIP docs:FILE:LINE: why"; the blocks not run are listed at the end.
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import docs_paste as paste

WILD = re.compile(r"\.\.\.|…")
NUM = re.compile(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
TIMEOUT = 600


class Example:
    def __init__(self, path, line, mode, opts, inputs, info, body):
        self.path, self.line, self.mode, self.opts = path, line, mode, opts
        self.inputs, self.info, self.body = inputs, info, body

    def name(self):
        return "docs:%s:%d" % (self.path, self.line)


def parse_marker(lines):
    """The mode, options and input lines of a docs-check comment."""
    head = lines[0].strip()[len("<!-- docs-check"):]
    inputs = [l for l in lines[1:]]
    if head.rstrip().endswith("-->"):
        head = head.rstrip()[:-3]
    if inputs and inputs[-1].strip() == "-->":
        inputs = inputs[:-1]
    elif inputs and inputs[-1].rstrip().endswith("-->"):
        inputs[-1] = inputs[-1].rstrip()[:-3]
    words = head.split()
    mode = "shell"
    if words and words[0].rstrip(":") == "skip":
        return "skip", {"why": " ".join(words[1:] + [l.strip() for l in inputs]).strip()}, []
    if words and words[0] in ("shell", "scene", "errors", "http"):
        mode = words.pop(0)
    opts = {"any": []}
    for w in words:
        if w.startswith("any="):
            opts["any"].append(w[4:])
        elif "=" in w:
            k, v = w.split("=", 1)
            opts[k] = v
        else:
            opts[w] = True
    return mode, opts, [l for l in inputs if l.strip()]


def examples(path, rel):
    """Every fenced block of one Markdown file, with its marker's mode (None
    when it has no marker)."""
    lines = open(path, encoding="utf-8").read().split("\n")
    out, i, pending = [], 0, None
    while i < len(lines):
        l = lines[i]
        if l.strip().startswith("<!-- docs-check"):
            j = i
            while "-->" not in lines[j]:
                j += 1
            pending = parse_marker(lines[i:j + 1])
            i = j + 1
            continue
        m = re.match(r"^(\s*)(```+)(.*)$", l)
        if m:
            fence, info, start = m.group(2), m.group(3).strip(), i
            j = i + 1
            while j < len(lines) and not lines[j].strip().startswith(fence):
                j += 1
            indent = len(m.group(1))
            body = [b[indent:] if b[:indent].strip() == "" else b for b in lines[i + 1:j]]
            mode, opts, inputs = pending or (None, {"any": []}, [])
            out.append(Example(rel, start + 1, mode, opts, inputs, info, body))
            pending = None
            i = j + 1
            continue
        if l.strip():
            pending = None  # a marker belongs to the block right after it
        i += 1
    return out


# ---- matching ------------------------------------------------------------------

def text_re(expected, opts):
    """A regex for one expected line (or string)."""
    for w in sorted(opts.get("any", []), key=len, reverse=True):
        expected = expected.replace(w, "\0")
    parts, pos = [], 0
    tokens = [WILD, NUM] if opts.get("any-numbers") else [WILD]
    pat = re.compile("|".join(t.pattern for t in tokens) + "|\0")
    for m in pat.finditer(expected):
        parts.append(re.escape(expected[pos:m.start()]))
        t = m.group(0)
        if t == "\0":
            parts.append(r"[A-Za-z0-9]+")
        elif WILD.fullmatch(t):
            parts.append(r".*?")
        else:
            parts.append(r"-?[0-9.]+(?:[eE][-+]?\d+)?")
        pos = m.end()
    parts.append(re.escape(expected[pos:]))
    return re.compile("^" + "".join(parts) + "$", re.S)


def text_match(expected, actual, opts):
    return bool(text_re(expected, opts).match(actual))


def json_match(exp, act, opts, where=""):
    """None when act matches exp, else why not."""
    if isinstance(exp, dict):
        if not isinstance(act, dict):
            return "%s: expected an object, got %s" % (where or "/", json.dumps(act)[:80])
        for k, v in exp.items():
            if k not in act:
                return "%s/%s: missing" % (where, k)
            why = json_match(v, act[k], opts, "%s/%s" % (where, k))
            if why:
                return why
        return None
    if isinstance(exp, list):
        if not isinstance(act, list) or len(act) != len(exp):
            return "%s: expected %d items, got %s" % (where or "/", len(exp), json.dumps(act)[:80])
        for i, (e, a) in enumerate(zip(exp, act)):
            why = json_match(e, a, opts, "%s/%d" % (where, i))
            if why:
                return why
        return None
    if isinstance(exp, str):
        if isinstance(act, str) and text_match(exp, act, opts):
            return None
    elif isinstance(exp, bool) or exp is None:
        if exp is act:
            return None
    elif isinstance(exp, (int, float)):
        if isinstance(act, (int, float)) and not isinstance(act, bool) and \
                (exp == act or opts.get("any-numbers")):
            return None
    return "%s: expected %s, got %s" % (where or "/", json.dumps(exp, ensure_ascii=False),
                                        json.dumps(act, ensure_ascii=False)[:200])


def lines_match(exp_lines, act_text, opts):
    """None when the actual text matches the expected lines, else why not."""
    exp = "\n".join(exp_lines).strip("\n")
    act = act_text.strip("\n")
    if exp.startswith("HTTP/"):
        return http_match(exp, act, opts)
    if exp[:1] in "{[":
        try:
            e = json.loads(exp)
        except ValueError:
            e = None
        if e is not None:
            try:
                a = json.loads(act)
            except ValueError:
                return "expected JSON, got %r" % act[:200]
            return json_match(e, a, opts)
    el, al = exp.split("\n"), act.split("\n")
    if len(el) != len(al):
        return "expected %d lines, got %d: %r" % (len(el), len(al), act[:300])
    for e, a in zip(el, al):
        if not text_match(e, a, opts):
            return "expected %r, got %r" % (e, a)
    return None


def http_match(exp, act, opts):
    act = act.replace("\r\n", "\n")
    eh, _, eb = exp.partition("\n\n")
    ah, _, ab = act.partition("\n\n")
    el, al = eh.split("\n"), ah.split("\n")
    es, as_ = el[0].split()[1:2], al[0].split()[1:2]
    if es != as_:
        return "expected status %s, got %r" % (es, al[0])
    headers = {}
    for h in al[1:]:
        k, _, v = h.partition(":")
        headers.setdefault(k.strip().lower(), []).append(v.strip())
    for h in el[1:]:
        k, _, v = h.partition(":")
        got = headers.get(k.strip().lower(), [])
        if not any(text_match(v.strip(), g, opts) for g in got):
            return "header %s: expected %r, got %r" % (k.strip(), v.strip(), got)
    if eb.strip():
        return lines_match(eb.split("\n"), ab, opts)
    return None


# ---- running ---------------------------------------------------------------------

class Env:
    """A rayd of its own for each example of the scene, errors and http
    modes, and rayd-render, both run from the repository."""

    def __init__(self, root, build):
        self.root, self.build = root, build
        self.work = tempfile.mkdtemp(prefix="rayd-docs.")
        os.mkdir(os.path.join(self.work, "assets"))
        with open(os.path.join(self.work, "token"), "w") as f:
            f.write("docs-check-token\n")
        self.rayd = None

    def start(self, opts):
        """A fresh rayd for each example, so none depends on another's caches."""
        self.stop()
        self.err = open(os.path.join(self.work, "rayd.err"), "w")
        args = [os.path.join(self.build, "rayd"), "--bind", "127.0.0.1", "--port", "0",
                "--threads", "2", "--asset-dir", os.path.join(self.work, "assets")]
        if opts.get("token"):
            args += ["--token-file", os.path.join(self.work, "token")]
        self.rayd = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=self.err, text=True)
        first = self.rayd.stdout.readline().strip()
        m = re.match(r"^rayd listening on http://127\.0\.0\.1:(\d+)$", first)
        if not m:
            raise SystemExit("FAIL docs_check_server: first line was %r" % first)
        self.port = m.group(1)

    def stop(self):
        if not self.rayd:
            return
        self.rayd.terminate()
        try:
            self.rayd.wait(60)
        except subprocess.TimeoutExpired:
            self.rayd.kill()
            self.rayd.wait()
        self.rayd.stdout.close()
        self.err.close()
        self.rayd = None

    def close(self):
        self.stop()
        shutil.rmtree(self.work, ignore_errors=True)

    def render_cli(self, scene, named=False):
        """rayd-render of the scene on stdin, in the root's folder (its assets'
        paths are the root's); named: as a file scene.json in a folder of its
        own, so that its errors name it as the docs show them
        ("rayd-render: error: scene.json: ...")."""
        cwd, arg = self.root, "-"
        if named:
            cwd, arg = os.path.join(self.work, "cli"), "scene.json"
            os.makedirs(cwd, exist_ok=True)
            with open(os.path.join(cwd, arg), "wb") as f:
                f.write(scene)
        p = subprocess.run([os.path.join(self.build, "rayd-render"), arg, "-o",
                            os.path.join(self.work, "docs-check.png")], input=scene, cwd=cwd,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=TIMEOUT)
        return p.returncode, p.stderr.decode("utf-8", "replace").strip()

    def http(self, method, target, body=None):
        args = ["curl", "-s", "-m", "300", "-X", method, "-o", "-", "-w", "\n%{http_code}"]
        if body is not None:
            args += ["-H", "Content-Type: application/json", "--data-binary", "@-"]
        args.append("http://127.0.0.1:%s%s" % (self.port, target))
        p = subprocess.run(args, input=body or b"", stdout=subprocess.PIPE, timeout=TIMEOUT)
        text, _, code = p.stdout.decode("utf-8", "replace").rpartition("\n")
        return int(code or 0), text


def scene_input(env, line):
    line = line.strip()
    if line.startswith("@"):
        return open(os.path.join(env.root, line[1:]), "rb").read()
    return (json.loads(line) if line.startswith('"') else line).encode()


def cli_error_parts(line):
    """(path, line, column, message) of a 'rayd-render: error: ...' line."""
    rest = re.sub(r"^(rayd-render: )?error: (scene\.json: )?", "", line)
    m = re.match(r"^line (\d+), column (\d+): (.*)$", rest)
    if m:
        return None, int(m.group(1)), int(m.group(2)), m.group(3)
    m = re.match(r"^(/[^:]*|/): (.*)$", rest)
    if m:
        return m.group(1), None, None, m.group(2)
    return None, None, None, rest


def check_errors(env, ex):
    block = [l for l in ex.body if l.strip()]
    if len(block) != len(ex.inputs):
        return "%d scenes in the marker for %d lines" % (len(ex.inputs), len(block))
    for scene_line, expected in zip(ex.inputs, block):
        scene = scene_input(env, scene_line)
        rc, err = env.render_cli(scene, named=True)
        if rc != 1 or not text_match(expected, err, ex.opts):
            return "rayd-render: expected exit 1 and %r, got exit %d and %r" % (expected, rc, err)
        if ex.opts.get("cli-only"):
            continue
        path, line, col, msg = cli_error_parts(expected)
        code, text = env.http("POST", "/v1/render", scene)
        try:
            e = json.loads(text)["error"]
        except (ValueError, KeyError, TypeError):
            return "server: expected a JSON error for %r, got %d %r" % (expected, code, text[:200])
        want = {"message": msg, "status": code}
        if path is not None:
            want["path"] = path
        if line is not None:
            want["line"], want["column"] = line, col
        why = json_match(want, e, ex.opts)
        if why or code < 400:
            return "server for %r: %s" % (expected, why or "status %d" % code)
    return None


def check_http(env, ex):
    block = [l for l in ex.body if l.strip()]
    if len(block) != len(ex.inputs):
        return "%d requests in the marker for %d lines" % (len(ex.inputs), len(block))
    for req, expected in zip(ex.inputs, block):
        parts = req.strip().split(None, 2)
        body = None
        if len(parts) > 2:
            body = (json.loads(parts[2]) if parts[2].startswith('"') else parts[2]).encode()
        code, text = env.http(parts[0], parts[1], body)
        why = lines_match([expected], text, ex.opts)
        if why:
            return "%s %s: %s" % (parts[0], parts[1], why)
        try:
            st = json.loads(text).get("error", {}).get("status", code)
        except (ValueError, AttributeError):
            st = code
        if st != code:
            return "%s %s: HTTP %d but the body says %s" % (parts[0], parts[1], code, st)
    return None


def session(body):
    """[(command, [expected output lines])] of a "$ " block."""
    out, cmd = [], None
    for l in body:
        if l.startswith("$ ") and (cmd is None or not cmd[0].endswith("\\")):
            cmd = [l[2:], []]
            out.append(cmd)
        elif cmd is not None and cmd[0].endswith("\\") and not cmd[1]:
            cmd[0] += "\n" + l
        elif cmd is not None:
            cmd[1].append(l)
    return out


def is_commands(ex):
    """A block a reader pastes into a shell: fenced as sh, bash, shell or
    console, or a session of "$ " lines, or marked for the shell."""
    tag = ex.info.split()[0] if ex.info.split() else ""
    return tag in paste.SHELL_TAGS or ex.mode == "shell" or \
        (tag == "" and any(l.startswith("$ ") for l in ex.body))


class Page:
    """A page's clone folder, server, shell and ports."""

    def __init__(self, root, build, clone, tmp):
        self.clone, self.tmp = clone, tmp
        if not os.path.exists(clone):
            paste.make_clone(root, build, clone)
        self.server = paste.Server(clone, tmp)
        self.ports = paste.Ports(self.server.port)
        self.shell = paste.Shell(clone, tmp)

    def close(self):
        self.shell.close()
        self.server.stop()


def http_codes(out):
    """(the output without curl's status lines, the statuses)."""
    codes, keep = [], []
    for l in out.split("\n"):
        m = re.search(r"docs-check-http (\d+)$", l)
        if m:
            codes.append(int(m.group(1)))
            l = l[:m.start()]
            if not l:
                continue
        keep.append(l)
    return "\n".join(keep), codes


def check_step(page, script, want_exit, compare):
    """Why one step (a block, or one command of a session) failed, or None."""
    script = page.ports.local(script)
    rc, out, fails, cwd = page.shell.run(script)
    out, codes = http_codes(out)
    tail = out.strip()[-300:]
    if rc is None or rc == -1:
        if rc == -1:
            page.shell.close()
            page.shell = paste.Shell(cwd, page.tmp)
            return "the shell ended: %s" % tail
        page.shell.close()
        page.shell = paste.Shell(cwd, page.tmp)
        return "still running after %d s (put it in the background, or stop it): %s" % (
            paste.BLOCK_SECONDS, tail)
    if want_exit is not None:
        if rc != want_exit:
            return "exit status %d (expected %d): %s" % (rc, want_exit, tail)
    elif rc != 0 or fails:
        return "%s: %s" % ("; ".join(fails[:3]) or "exit status %d" % rc, tail)
    for bad in ("Traceback (most recent call last)", "command not found"):
        if bad in out:
            return "%r in its output: %s" % (bad, tail)
    bad = [c for c in codes if c >= 400]
    if bad and compare is None and want_exit is None:
        return "HTTP status %s: %s" % (bad, tail)
    why = paste.file_problems(script, cwd)
    if why:
        return "; ".join(why)
    if compare and any(l.strip() for l in compare[0]):
        return lines_match([page.ports.local(l) for l in compare[0]], out, compare[1])
    return None


def check_commands(page, ex):
    """A command block pasted: a session command by command, else whole."""
    want = int(ex.opts["exit"]) if "exit" in ex.opts else None
    if not any(l.startswith("$ ") for l in ex.body):
        return check_step(page, "\n".join(ex.body), want, None)
    for cmd, expected in session(ex.body):
        compare = (expected, ex.opts) if ex.mode == "shell" else None
        why = check_step(page, cmd, want, compare)
        if why:
            return "%r: %s" % (cmd[:60], why)
    return None


def check_scene(env, ex):
    rc, err = env.render_cli("\n".join(ex.body).encode())
    return None if rc == 0 else "rayd-render: exit %d: %s" % (rc, err)


def check_page(env, clone, tmp, f, rel, results, say=print):
    """Every block of one page, in order; one line each."""
    page, checks = None, {"scene": check_scene, "errors": check_errors, "http": check_http}
    try:
        for ex in examples(f, rel):
            if ex.mode == "skip":
                results.append(("SKIP", ex.name(), ex.opts["why"] or "no reason given"))
                say("SKIP %s: %s" % (ex.name(), results[-1][2]))
                continue
            t0 = time.monotonic()
            try:
                if ex.mode in checks:
                    env.start(ex.opts)
                    why = checks[ex.mode](env, ex)
                elif is_commands(ex):
                    page = page or Page(env.root, env.build, clone, tmp)
                    why = check_commands(page, ex)
                else:
                    continue
            except subprocess.TimeoutExpired:
                why = "no answer within %d s" % TIMEOUT
            except RuntimeError as e:  # the page's rayd did not start
                why = str(e)
            results.append(("FAIL" if why else "PASS", ex.name(), why))
            took = "%.1f s" % (time.monotonic() - t0)
            if why:
                say("FAIL %s: %s (%s)" % (ex.name(), why.replace("\n", "\\n"), took))
            else:
                say("PASS %s (%s)" % (ex.name(), took))
    finally:
        if page:
            page.close()


# (what the block must give, and for a FAIL a part of the reason; its marker
# or None; the block): each rule of docs_paste.py broken once, alone, in one
# page, in order.
SELF_TEST = [
    ("PASS", None, 'x=42\ncurl --fail -s -H "Content-Type: application/json" --data-binary '
     '@scenes/spheres.json "http://127.0.0.1:8080/v1/render?x=0&y=0&w=8&h=8" -o ok.png'),
    ("PASS", None, '[ "$x" = 42 ] && [ -s ok.png ]  # the shell and the files of the page'),
    ("FAIL:HTTP status [404]", None, "curl -s http://127.0.0.1:8080/v1/no-such-route"),
    ("FAIL:'Traceback", None, "python3 -c 'import json; json.loads(\"{}\")[\"id\"]' || true"),
    ("FAIL:command not found", None, "no-such-command-here || true"),
    ("FAIL:no-such-scene.json does not exist", None, "echo scenes/no-such-scene.json"),
    ("FAIL:exit 1: false", None, "false\ntrue"),
    ("FAIL:job.exr is not EXR", None, "printf '{\"id\": 1}' >job.exr"),
    ("FAIL:waits for the job", None, "echo curl -N http://127.0.0.1:8080/v1/jobs/x/events\ntrue"),
    ("PASS", "exit=3", "(exit 3)"),
    ("SKIP", "skip: never run", "false"),
    ("PASS", "", "$ echo hi\nhi"),
    ("FAIL:expected 'ho'", "", "$ echo hi\nho"),
    ("FAIL:still running after 3 s", None, "sleep 30"),
]


def self_test(root, build):
    """Each rule seen to fail its block (and only it)."""
    tmp = tempfile.mkdtemp(prefix="rayd-docs-self.")
    page = os.path.join(tmp, "page.md")
    with open(page, "w") as f:
        for _, marker, block in SELF_TEST:
            if marker is not None:
                f.write("<!-- docs-check %s -->\n" % marker)
            f.write("```sh\n%s\n```\n\n" % block)
    env, results = Env(root, build), []
    paste.BLOCK_SECONDS = 3
    try:
        clone = os.path.join(tmp, "rayd")
        check_page(env, clone, tmp, page, "page.md", results, say=lambda line: None)
    finally:
        env.close()
        shutil.rmtree(tmp, ignore_errors=True)
    bad = 0
    for (want, marker, block), got in zip(SELF_TEST, results):
        want, _, why = want.partition(":")
        ok = got[0] == want and why in (got[2] or "")
        bad += not ok
        print("%s docs_check self-test: %s gives %s%s" % (
            "PASS" if ok else "FAIL", json.dumps(block.split("\n")[0][:50]), want,
            "" if ok else ", got %s: %s" % (got[0], got[2])))
    if len(results) != len(SELF_TEST):
        print("FAIL docs_check self-test: %d results for %d blocks" % (len(results), len(SELF_TEST)))
        bad += 1
    return 1 if bad else 0


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    build = os.path.abspath(sys.argv[1])
    if sys.argv[2] == "--self-test":
        return self_test(root, build)
    env = Env(root, build)
    results = []
    tmp = tempfile.mkdtemp(prefix="rayd-docs-paste.")
    try:
        for f in sys.argv[2:]:
            # Each page starts from a fresh clone, as a reader who opens it first.
            rel = os.path.relpath(os.path.abspath(f), root)
            page_tmp = tempfile.mkdtemp(prefix="page.", dir=tmp)
            clone = os.path.join(page_tmp, "rayd")
            check_page(env, clone, page_tmp, f, rel, results)
    finally:
        env.close()
        shutil.rmtree(tmp, ignore_errors=True)
    skips = [r for r in results if r[0] == "SKIP"]
    if skips:
        print("docs_check: %d block(s) not run, each for the reason its marker gives: %s" % (
            len(skips), ", ".join(r[1] for r in skips)))
    if not any(r[0] != "SKIP" for r in results):
        print("FAIL docs_check: no example found in %s" % " ".join(sys.argv[2:]))
        return 1
    return 1 if any(r[0] == "FAIL" for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
