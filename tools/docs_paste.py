"""docs_paste.py -- the docs' command blocks pasted, in order, into one shell per
page, in a fresh copy of the repository, as a newcomer would after `make run`.

tools/docs_check.py imports it.  A page is read top to bottom; each command
block (fenced as sh, bash, shell or console, or any block of "$ " lines) is
written to a file and sourced by one bash that lives as long as the page, so
a variable, a file or a background job of one block is there for the next,
as in a terminal.  The shell's working folder is a copy of the files git
tracks (in their working-tree state: an edited page is checked before it is
committed; a file never added to git is not there, as in a clone), with the
already built build/ linked in, so nothing is rebuilt.  One change is made
to the copy: the path-traced scenes of scenes/ are cut to 64 x 64 pixels
(same samples, same passes), so that the whole run takes seconds, not
minutes.

The page's server is started as `make run THREADS=2` starts it (build/rayd
--bind 127.0.0.1 --threads 2 --data-dir ...), on a free port instead of 8080; every
127.0.0.1:PORT or localhost:PORT of a block, and `--port PORT`, with PORT
from 8000 to 8999, is rewritten to a free port (8080 to that server's), so
a block that starts a rayd of its own (`build/rayd --port 8081 ... &`) works
too.

A block fails on a nonzero exit status of any command in it (an ERR trap
sees each one; a `<!-- docs-check exit=N -->` marker says that the block's
last command exits N), on "Traceback" or "command not found" in its output,
on an HTTP status of 400 or more (or none: no server) that curl got (from a
curlrc write-out; a marked session compares its output instead), on an image
file (.png, .exr, .mp4, ...) it wrote that is not one (the JSON of an error or
of a 202 saved under an image's name), on a file it names that does not
exist once it ran, and on running longer than BLOCK_SECONDS (a blocking
step must be put in the background or explained).
"""
import glob
import json
import os
import re
import select
import shlex
import shutil
import signal
import socket
import subprocess
import tempfile

SHELL_TAGS = ("sh", "bash", "shell", "console")
BLOCK_SECONDS = 60
# The first bytes of each kind of file an example promises.
MAGIC = {
    ".png": [(0, b"\x89PNG\r\n\x1a\n")],
    ".exr": [(0, b"v/1\x01")],
    ".mp4": [(4, b"ftyp")],
    ".mov": [(4, b"ftyp"), (4, b"moov"), (4, b"wide")],
    ".mkv": [(0, b"\x1a\x45\xdf\xa3")],
    ".hdr": [(0, b"#?RADIANCE"), (0, b"#?RGBE")],
    ".jpg": [(0, b"\xff\xd8\xff")],
    ".pfm": [(0, b"PF"), (0, b"Pf")],
}
# Words that name a file when they have a slash or one of these extensions.
FILE_EXT = ("json", "obj", "ply", "glb", "gltf", "bin", "hdr", "exr", "png", "mp4", "mov", "mkv",
            "jpg", "txt", "pem", "sh", "py", "md", "conf", "yml", "yaml", "service")
# Options and commands whose next word is an output (checked for its kind, not for existence).
OUT_OPTS = ("-o", "--output", ">", ">>", "-D", "--dump-header", "--pass-output", "--video",
            "tee", "mkdir", "--data-dir", "rm", "cd", "2>", "&>")
# Options and commands whose next word is an input, with or without a slash.
IN_OPTS = ("cat", "--token-file", "--tls-cert", "--tls-key", "--asset-dir", "<", "source", ".")
PATHY = re.compile(r"^[A-Za-z0-9_.~/+-]+$")
PORT_RE = re.compile(r"(?<![\w.-])((?:127\.0\.0\.1|localhost):)(8\d\d\d)\b|(--port[= ])(8\d\d\d)\b")


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def tracked_files(root):
    """The files a clone would hold: git's, as they are in the working tree."""
    try:
        out = subprocess.run(["git", "-C", root, "ls-files", "-z"], capture_output=True,
                             check=True).stdout.decode()
        files = [f for f in out.split("\0") if f and os.path.lexists(os.path.join(root, f))]
        if files:
            return files
    except (OSError, subprocess.CalledProcessError):
        pass
    files = []
    for d, dirs, names in os.walk(root):
        dirs[:] = [x for x in dirs if not x.startswith(".") and x not in ("build", "node_modules")]
        files += [os.path.relpath(os.path.join(d, n), root) for n in names]
    return files


def make_clone(root, build, dst):
    """dst as a fresh clone's root, build/ linked to the built tree."""
    for f in tracked_files(root):
        src, out = os.path.join(root, f), os.path.join(dst, f)
        os.makedirs(os.path.dirname(out), exist_ok=True)
        if os.path.islink(src):
            os.symlink(os.readlink(src), out)
        elif os.path.isfile(src):
            shutil.copy2(src, out)
    cut_scenes(os.path.join(dst, "scenes"))
    os.symlink(build, os.path.join(dst, "build"))


def cut_scenes(folder):
    """Path-traced scenes at 64 x 64 at most (the same samples, so the same
    passes); the file keeps its time, so make sees nothing to rebuild."""
    if not os.path.isdir(folder):
        return
    for f in sorted(os.listdir(folder)):
        p = os.path.join(folder, f)
        if not f.endswith(".json") or os.path.islink(p):
            continue
        try:
            s = json.load(open(p, encoding="utf-8"))
        except ValueError:
            continue
        r = s.get("render", {}) if isinstance(s, dict) else {}
        if not isinstance(r, dict) or r.get("integrator") != "path":
            continue
        st = os.stat(p)
        r["width"], r["height"] = min(r.get("width", 640), 64), min(r.get("height", 480), 64)
        json.dump(s, open(p, "w"))
        os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns))


class Ports:
    """Doc ports (8000-8999) to free ones: 8080 to the page's server."""

    def __init__(self, main):
        self.map = {"8080": str(main)}

    def local(self, text):
        def sub(m):
            if m.group(2):
                return m.group(1) + self.port(m.group(2))
            return m.group(3) + self.port(m.group(4))
        return PORT_RE.sub(sub, text)

    def port(self, p):
        if p not in self.map:
            self.map[p] = str(free_port())
        return self.map[p]


class Server:
    """The page's rayd, started as `make run THREADS=2` starts it (two
    workers: the same answers, `workers 0 busy of 2`, on any machine)."""

    def __init__(self, clone, tmp):
        self.err = open(os.path.join(tmp, "rayd.err"), "w")
        data = tempfile.mkdtemp(prefix="data.", dir=tmp)
        self.proc = subprocess.Popen([os.path.join(clone, "build/rayd"), "--bind", "127.0.0.1",
                                      "--port", "0", "--threads", "2", "--data-dir", data],
                                     cwd=clone,
                                     stdout=subprocess.PIPE, stderr=self.err, text=True)
        first = self.proc.stdout.readline().strip()
        m = re.match(r"^rayd listening on http://127\.0\.0\.1:(\d+)$", first)
        if not m:
            self.stop()
            raise RuntimeError("rayd's first line was %r" % first)
        self.port = int(m.group(1))

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.proc.stdout.close()
        self.err.close()


class Shell:
    """One bash for a page; each step is a file it sources."""

    def __init__(self, cwd, tmp):
        self.cwd, self.tmp, self.n = cwd, tmp, 0
        rc = os.path.join(tmp, ".curlrc")
        with open(rc, "w") as f:
            f.write('write-out = "%{stderr}docs-check-http %{http_code}\\n"\n')
        env = dict(os.environ, CURL_HOME=tmp, TERM="dumb")
        # A page's `make` is a newcomer's plain make: nothing from a make
        # running this check (make test SANITIZE=1 passes SANITIZE down in
        # MAKEFLAGS, which would build build/asan/ afresh inside the copy).
        for k in ("RAYD_TOKEN", "MAKEFLAGS", "MFLAGS", "MAKELEVEL", "MAKEOVERRIDES",
                  "SANITIZE", "TSAN", "NATIVE", "BUILD", "CFLAGS", "LDFLAGS"):
            env.pop(k, None)
        self.rfd, wfd = os.pipe()
        self.wfd = wfd
        self.proc = subprocess.Popen(["bash", "--norc", "--noprofile"], cwd=cwd, env=env,
                                     stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL, pass_fds=(wfd,),
                                     start_new_session=True)
        os.close(wfd)
        self.buf = b""

    def run(self, script):
        """(exit status, None when it ran out of time or -1 when the shell
        ended (an `exit`), output, failed commands, cwd)."""
        self.n += 1
        base = os.path.join(self.tmp, "step%d" % self.n)
        with open(base + ".sh", "w") as f:
            f.write(script + "\n")
        open(base + ".err", "w").close()
        trap = "trap 'printf \"line %%s: exit %%s: %%s\\n\" \"$LINENO\" \"$?\" \"$BASH_COMMAND\" >>%s' ERR" \
            % shlex.quote(base + ".err")
        cmd = ("%s\nsource %s >%s 2>&1 </dev/null %d>&-\n__dc_rc=$?\ntrap - ERR\n"
               "printf 'docs-check-done %%s %%s\\n' \"$__dc_rc\" \"$PWD\" >&%d\n") % (
            trap, shlex.quote(base + ".sh"), shlex.quote(base + ".out"), self.wfd, self.wfd)
        try:
            self.proc.stdin.write(cmd.encode())
            self.proc.stdin.flush()
        except BrokenPipeError:
            return -1, "(the shell had ended)", [], self.cwd
        line = self.read_line(BLOCK_SECONDS)
        if line == "":
            return -1, "(the shell ended: an exit in the block?)", [], self.cwd
        out = open(base + ".out", encoding="utf-8", errors="replace").read()
        fails = [l for l in open(base + ".err", encoding="utf-8", errors="replace").read().split("\n")
                 if l and ": source " not in l]
        if line is None:
            return None, out, fails, self.cwd
        _, rc, cwd = line.split(" ", 2)
        self.cwd = cwd
        return int(rc), out, fails, cwd

    def read_line(self, timeout):
        while b"\n" not in self.buf:
            r, _, _ = select.select([self.rfd], [], [], timeout)
            if not r:
                return None
            chunk = os.read(self.rfd, 4096)
            if not chunk:
                return ""
            self.buf += chunk
        line, self.buf = self.buf.split(b"\n", 1)
        return line.decode()

    def close(self):
        """Ends the shell and every job it left in the background (its own
        process group, made for it)."""
        try:
            os.killpg(self.proc.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
        os.close(self.rfd)


# ---- what a block names --------------------------------------------------------------

def strip_heredocs(text):
    """The text without here-documents' bodies (they are data, not commands)."""
    out, end = [], None
    for l in text.split("\n"):
        if end is not None:
            if l.strip() == end:
                end = None
            continue
        out.append(l)
        m = re.search(r"<<-?\s*['\"]?(\w+)['\"]?", l)
        if m:
            end = m.group(1)
    return "\n".join(out)


def substitutions(text):
    """The commands inside $( ... ), nested ones too."""
    out, i = [], 0
    while True:
        i = text.find("$(", i)
        if i < 0:
            return out
        depth, j = 1, i + 2
        while j < len(text) and depth:
            depth += {"(": 1, ")": -1}.get(text[j], 0)
            j += 1
        inner = text[i + 2:j - 1]
        out.append(inner)
        out += substitutions(inner)
        i += 2


def words(text):
    lex = shlex.shlex(text, posix=True, punctuation_chars=";&|<>()")
    lex.whitespace_split = True
    try:
        return list(lex)
    except ValueError:
        return []


def named_files(script):
    """([input files], [output files]) a script names, as written; an input
    that is a file only if its first folder exists ends with a NUL."""
    text = strip_heredocs(script.replace("\\\n", " "))
    ins, outs = [], []
    for cmd in [text] + substitutions(text):
        ws = words(cmd)
        for k, w in enumerate(ws):
            prev = ws[k - 1] if k else ""
            if prev == "2" and w.startswith(">"):
                continue
            if w.startswith("@"):
                w = w[1:]
            if not w or not PATHY.match(w) or w.startswith("-") or w.startswith("/dev/") or \
                    w in ("-", ".", ".."):
                continue
            if prev in OUT_OPTS:
                outs.append(w)
            elif prev in IN_OPTS or "." in w and w.rsplit(".", 1)[-1] in FILE_EXT or \
                    w.endswith("/") or w.startswith("/"):
                ins.append(w)
            elif "/" in w:
                ins.append(w + "\0")  # a file only if its first folder is there (not image/png)
    return ins, outs


def foreground_streams(script):
    """The lines that follow an event stream in the foreground with more
    lines after them: those run only once the job has ended (a stream of a
    long job blocks for minutes), so what they do to the job is not what
    the page says."""
    lines = [words(l) for l in strip_heredocs(script.replace("\\\n", " ")).split("\n")]
    lines = [w for w in lines if w]
    out = []
    for k, w in enumerate(lines[:-1]):
        if "curl" in w and any(x.rstrip("'\"").endswith("/events") for x in w) and w[-1] != "&":
            out.append(" ".join(w))
    return out


def with_pattern(folder, name):
    """The files a %d / %04d output name stands for."""
    return glob.glob(os.path.join(folder, re.sub(r"%0?\d*d", "*", name)))


def file_problems(script, cwd):
    """Why the files a block names are wrong: a missing input, an image that is not one."""
    ins, outs = named_files(script)
    why = ["%r waits for the job's end before the lines after it run (put it in the background: "
           "`... &`)" % l[:80] for l in foreground_streams(script)]
    for f in ins:
        if f.endswith("\0"):
            f = f[:-1]
            if not os.path.isdir(os.path.join(cwd, f.split("/")[0])):
                continue
        if "%" in f:
            continue
        if not os.path.lexists(os.path.join(cwd, os.path.expanduser(f))) and \
                not shutil.which(f):
            why.append("%s does not exist" % f)
    for f in outs:
        ext = os.path.splitext(f)[1].lower()
        if ext not in MAGIC:
            continue
        for p in with_pattern(cwd, f) if "%" in f else [os.path.join(cwd, f)]:
            bad = not_an_image(p, ext)
            if bad:
                why.append("%s is not %s: %s" % (os.path.relpath(p, cwd), ext[1:].upper(), bad))
    return why


def not_an_image(path, ext):
    """None when path holds the kind ext promises (or is absent or empty: still being written)."""
    try:
        head = open(path, "rb").read(64)
    except OSError:
        return None
    if not head:
        return None
    if any(head[o:o + len(m)] == m for o, m in MAGIC[ext]):
        return None
    text = head.decode("utf-8", "replace")
    return "it holds %r" % (text[:60] + ("..." if len(text) > 60 else ""))
