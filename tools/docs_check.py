#!/usr/bin/env python3
"""docs_check.py -- runs the examples of README.md and docs/*.md and compares
their answers with what the docs say, so the docs cannot drift from rayd.

    python3 tools/docs_check.py BUILD FILE.md...

Only examples marked for it are run: an HTML comment that starts with
"<!-- docs-check" just before a fenced block (blank lines between are
allowed).  The comment is invisible on GitHub; its first line names a mode
and options, its other lines (up to "-->") are the mode's inputs:

  <!-- docs-check -->            (mode "shell", the default) the block's shell
      commands run with bash in a scratch folder that sees the repository's
      build/, scenes/, programs/, tests/ and docs/ (build/ is BUILD; in
      scenes/ the path-traced scenes are cut to 64 x 64 pixels, same
      samples, so that they take seconds; scene.json is scenes/spheres.json).  A block
      of lines starting with "$ " is a session: each command (with "\"
      continuations) runs in turn and must exit 0, and the lines after it,
      up to the next "$ ", are its expected output (stdout and stderr).  A
      block without "$ " is one script that must exit 0 with every HTTP
      answer curl gets below 400.
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
are ignored); arrays must have the same length.

Each example talks to a rayd of its own, started for it on 127.0.0.1
--port 0 with --threads 2 (the same answers on any machine) and
--asset-dir the scratch folder's assets/ (with the option "token", also
--token-file the scratch folder's token); "127.0.0.1:8080" and
"localhost:8080" in an example and in its expected output become its
address.  Each example prints one line, "PASS docs:FILE:LINE" or
"FAIL docs:FILE:LINE: why".
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

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
    """Every marked example of one Markdown file."""
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
            if pending:
                mode, opts, inputs = pending
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
    """The scratch folder, the server and the programs."""

    def __init__(self, root, build):
        self.root, self.build = root, build
        self.work = tempfile.mkdtemp(prefix="rayd-docs.")
        for d in ("programs", "tests", "docs"):
            os.symlink(os.path.join(root, d), os.path.join(self.work, d))
        self.scenes(os.path.join(root, "scenes"), os.path.join(self.work, "scenes"))
        os.symlink(build, os.path.join(self.work, "build"))
        os.mkdir(os.path.join(self.work, "assets"))
        shutil.copy(os.path.join(root, "scenes/spheres.json"), os.path.join(self.work, "scene.json"))
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

    @staticmethod
    def scenes(src, dst):
        """scenes/ as the repository's, but path-traced ones at 64 x 64 at
        most (same samples, so the same passes): they render in seconds.
        Other files (sky.hdr) are linked as they are."""
        os.mkdir(dst)
        for f in sorted(os.listdir(src)):
            if not f.endswith(".json"):
                os.symlink(os.path.join(src, f), os.path.join(dst, f))
                continue
            s = json.load(open(os.path.join(src, f), encoding="utf-8"))
            r = s.get("render", {})
            if r.get("integrator") != "path":
                os.symlink(os.path.join(src, f), os.path.join(dst, f))
                continue
            r["width"], r["height"] = min(r.get("width", 640), 64), min(r.get("height", 480), 64)
            json.dump(s, open(os.path.join(dst, f), "w"))

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

    def local(self, text):
        return text.replace("127.0.0.1:8080", "127.0.0.1:" + self.port) \
                   .replace("localhost:8080", "127.0.0.1:" + self.port)

    def bash(self, script):
        """(exit status, output without the HTTP status lines, HTTP statuses)."""
        prelude = ("curl() { command curl -w '%{stderr}docs-check-http %{http_code}\\n' \"$@\"; }\n"
                   "export -f curl\n")
        p = subprocess.run(["bash", "-c", prelude + self.local(script)], cwd=self.work,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                           timeout=TIMEOUT)
        codes, out = [], []
        for l in p.stdout.split("\n"):
            m = re.fullmatch(r"docs-check-http (\d+)", l)
            if m:
                codes.append(int(m.group(1)))
            else:
                out.append(l)
        return p.returncode, "\n".join(out), codes

    def render_cli(self, scene):
        p = subprocess.run([os.path.join(self.build, "rayd-render"), "-", "-o",
                            os.path.join(self.work, "docs-check.png")], input=scene, cwd=self.work,
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
    rest = re.sub(r"^(rayd-render: )?error: ", "", line)
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
        rc, err = env.render_cli(scene)
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


def check_shell(env, ex):
    if not any(l.startswith("$ ") for l in ex.body):
        rc, out, codes = env.bash("set -e\n" + "\n".join(ex.body))
        bad = [c for c in codes if c >= 400 or c == 0]
        if rc != 0:
            return "exit status %d: %s" % (rc, out.strip()[-300:])
        if bad:
            return "HTTP status %s: %s" % (bad, out.strip()[-300:])
        return None
    for cmd, expected in session(ex.body):
        rc, out, _ = env.bash(cmd)
        want_rc = int(ex.opts.get("exit", 0))
        if rc != want_rc:
            return "%r: exit status %d (expected %d): %s" % (cmd[:60], rc, want_rc, out.strip()[-300:])
        if any(l.strip() for l in expected):
            why = lines_match([env.local(l) for l in expected], out, ex.opts)
            if why:
                return "%r: %s" % (cmd[:60], why)
    return None


def check_scene(env, ex):
    rc, err = env.render_cli("\n".join(ex.body).encode())
    return None if rc == 0 else "rayd-render: exit %d: %s" % (rc, err)


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    build = os.path.abspath(sys.argv[1])
    env = Env(root, build)
    checks = {"shell": check_shell, "scene": check_scene, "errors": check_errors,
              "http": check_http}
    fails = n = 0
    try:
        for f in sys.argv[2:]:
            rel = os.path.relpath(os.path.abspath(f), root)
            for ex in examples(f, rel):
                n += 1
                try:
                    env.start(ex.opts)
                    why = checks[ex.mode](env, ex)
                except subprocess.TimeoutExpired:
                    why = "no answer within %d s" % TIMEOUT
                if why:
                    fails += 1
                    print("FAIL %s: %s" % (ex.name(), why.replace("\n", "\\n")), flush=True)
                else:
                    print("PASS %s" % ex.name(), flush=True)
    finally:
        env.close()
    if n == 0:
        print("FAIL docs_check: no example marked <!-- docs-check --> in %s" % " ".join(sys.argv[2:]))
        return 1
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
