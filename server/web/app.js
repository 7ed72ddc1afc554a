// app.js -- the preview page: wires the editor, the renderer and the camera.
//
// States (body[data-state], read by the tests too): loading, rendering,
// orbit (low-resolution frames while the camera moves), done, error,
// stopped (the Stop button or Esc), linked (a scene from a link waits for
// the user's Render: see "a link's scene").  Each finished full render bumps
// body[data-renders].  window.rayd exposes the measurements (stats) the
// browser tests and the README's figures use.
//
// The page keeps work: every change of the text, camera moves and examples
// included, is a step of the editor's undo history (an undone camera move or
// example renders again); the text is saved in local storage at each change
// and comes back after a reload.
//
// Strings of the scene too long for the textarea (an opened model's data)
// are folded into tokens in the editor (fold.js); sent() is the scene as it
// leaves the page, unfolded.
//
// The page acts only for its user: it sends the token for a scene the user
// started, never for one a link brought (a link is anyone's; see openHash).

import { examples } from "./examples.js";
import { parse, pointerOffset, lineOf, offsetOfLine, replaceAt, fmtVector, format, JsonSyntaxError } from "./json.js";
import { Api, ApiError, Renderer, isAbort, sizeOf } from "./render.js";
import { cameraOf, orbit, dolly } from "./camera.js";
import { eyeFloor } from "./ground.js";
import { Editor, undoKey } from "./editor.js";
import { linkFor, fromHash } from "./share.js";
import { View } from "./view.js";
import { loadSaved, save } from "./autosave.js";
import { JobsView, paneTabs } from "./jobs.js";
import { readFiles, ACCEPT } from "./model.js";
import { withModels, foldFiles, utf8Length, tooLargeMessage, wireDrop } from "./drop.js";
import { fold, unfold } from "./fold.js";

const $ = (id) => document.getElementById(id);
const DEFAULT_EXAMPLE = "whitted";

const editor = new Editor($("editor"));
const canvas = $("canvas");
const tokenInput = $("token");
tokenInput.value = localStorage.getItem("rayd.token") || "";
tokenInput.addEventListener("change", () => localStorage.setItem("rayd.token", tokenInput.value.trim()));
const api = new Api(() => tokenInput.value.trim());
const renderer = new Renderer(canvas, api);

// The canvas holds the image at its own size; CSS scales it to fit the
// stage, or shows it 1:1 (the 1:1 button, or the key 1).
const view = new View($("stage"), canvas);
renderer.onResize = () => view.apply();
view.onToggle = (on) => $("one").setAttribute("aria-pressed", String(on));
$("one").addEventListener("click", () => view.toggle());

const stats = {
  renders: 0, // full renders finished
  lastFullMs: 0, // from the click (or page start) to the last tile drawn
  lastPreviewMs: 0, // to the quick pass
  previewFrames: 0, // low-resolution frames drawn while moving the camera
  previewMs: [], // time of each of them
  raysPerSec: 0,
  passes: [], // a path-traced render's passes drawn: {samples, ms}
  firstPassMs: 0, // to the first whole (noisy) frame of a path-traced render
};
window.rayd = { stats, editor, view, render: () => render({ user: true }), sceneText: () => unfold(editor.value) };

// The Jobs tab (jobs.js): listed when first shown; "Render as job" sends
// the editor's text, as the user asked (a link's scene too: the click is
// the user's).
let jobsLoaded = null;
const tabs = paneTabs((name) => {
  if (name === "jobs" && !jobsLoaded) jobsLoaded = jobs.load();
  return jobsLoaded;
});
const jobs = new JobsView(api, {
  text: () => unfold(editor.value),
  scene: () => sceneOf(parsed()),
  show: () => tabs.select("jobs"),
});
window.rayd.jobs = jobs;

// ---- parsed state of the text ---------------------------------------------------
let doc = { text: null, root: null, error: null };
function parsed() {
  const text = editor.value;
  if (doc.text !== text) {
    try {
      doc = { text, root: parse(text), error: null };
    } catch (e) {
      doc = { text, root: null, error: e instanceof JsonSyntaxError ? e : new JsonSyntaxError(String(e), 0) };
    }
  }
  return doc;
}

// The scene as sent: the parsed tree's value, or, when the text holds folded
// strings, the unfolded text's (parsed once per text).
function sceneOf(d) {
  if (!d.root) return null;
  const full = unfold(d.text);
  if (full === d.text) return d.root.value;
  if (d.full === undefined) {
    try {
      d.full = JSON.parse(full);
    } catch (_) {
      d.full = d.root.value;
    }
  }
  return d.full;
}

function describe() {
  const d = parsed();
  const size = d.root ? sizeOf(d.root.value) : null;
  const r = (d.root && d.root.value.render) || {};
  const lines = d.text.split("\n").length;
  $("docinfo").textContent = `${lines} lines` + (d.error ? " · malformed JSON" : "");
  $("imginfo").textContent = size ? `${size[0]} × ${size[1]} · ${r.samples || 1} spp` : "";
}

// ---- status ----------------------------------------------------------------------
let timer = 0;
let t0 = 0;
let lastProgress = { done: 0, total: 0 };
let raysAtStart = null;
let raysNow = null;

function setState(s) {
  document.body.dataset.state = s;
  $("stop").disabled = !(s === "rendering" || s === "orbit");
}
const fmtMs = (ms) => (ms < 1000 ? `${Math.round(ms)} ms` : `${(ms / 1000).toFixed(2)} s`);
const fmtRate = (r) =>
  r >= 1e9 ? `${(r / 1e9).toFixed(2)} G` : r >= 1e6 ? `${(r / 1e6).toFixed(1)} M` : r >= 1e3 ? `${(r / 1e3).toFixed(0)} k` : `${Math.round(r)} `;

function status(text) {
  $("status").textContent = text;
}
function bar(frac) {
  $("bar").style.width = `${Math.max(0, Math.min(1, frac)) * 100}%`;
}
let doneAt = 0;
function progressText(final) {
  const ms = (final && doneAt ? doneAt : performance.now()) - t0;
  const parts = [];
  if (lastProgress.samples) parts.push(`${lastProgress.samples} spp · pass ${lastProgress.done}/${lastProgress.total}`);
  else if (lastProgress.total) parts.push(`${lastProgress.done}/${lastProgress.total} tiles`);
  else parts.push("quick pass");
  if (raysAtStart !== null && raysNow !== null && raysNow > raysAtStart) {
    stats.raysPerSec = ((raysNow - raysAtStart) * 1000) / ms;
    parts.push(`${fmtRate(stats.raysPerSec)}rays/s`);
  } else if (final && raysNow !== null && raysNow === raysAtStart) parts.push("from cache");
  parts.push(fmtMs(ms));
  return parts.join(" · ");
}

function startClock(signalGen) {
  stopClock();
  t0 = performance.now();
  lastProgress = { done: 0, total: 0 };
  raysAtStart = raysNow = null;
  api.raysTotal().then((r) => {
    if (gen === signalGen) raysAtStart = raysNow = r;
  });
  let polls = 0;
  timer = setInterval(() => {
    if (gen !== signalGen) return;
    status((lastProgress.samples ? "Refining · " : "Rendering · ") + progressText(false));
    if (++polls % 5 === 0 && raysAtStart !== null)
      api.raysTotal().then((r) => {
        if (gen === signalGen && r !== null) raysNow = r;
      });
  }, 100);
}
function stopClock() {
  clearInterval(timer);
  timer = 0;
}

// ---- errors ----------------------------------------------------------------------
let retryAction = null;
let gotoOffset = -1;

function clearError() {
  $("error").hidden = true;
  editor.markError(0);
}

function showError(title, message, { line = 0, offset = -1, retry = null } = {}) {
  stopClock();
  setState("error");
  $("linknote").hidden = true; // shown again by the next render while the link waits
  $("error").hidden = false;
  $("error").querySelector(".error-title").textContent = title;
  $("error").querySelector(".error-msg").textContent = message;
  retryAction = retry;
  $("retry").hidden = !retry;
  gotoOffset = offset;
  $("goto").hidden = offset < 0;
  editor.markError(line);
  status(title);
  bar(1);
}

function reportError(e, text) {
  if (!(e instanceof ApiError)) {
    showError("Error", String((e && e.message) || e), { retry: () => render({ user: true }) });
    return;
  }
  if (e.network) {
    showError("Cannot reach the server", `${e.message}\nIs rayd still running at ${location.origin}?`, {
      retry: () => render({ user: true }),
    });
    return;
  }
  if (e.status === 503) {
    showError(
      `Server busy (${e.status} ${e.code})`,
      `${e.message}\nrayd is ${e.code === "draining" ? "shutting down" : "full"}; try again in a moment.`,
      { retry: () => render({ user: true }) }
    );
    return;
  }
  if (e.job) {
    // a progressive job that ended without its image: no HTTP status to show
    const canceled = e.code === "job_canceled";
    showError(
      `${canceled ? "Render cancelled" : "Render failed"} (${e.code})`,
      canceled ? `${e.message}\nrayd cancelled the job (deleted by another client, or shutting down).` : e.message,
      { retry: () => render({ user: true }) }
    );
    return;
  }
  if (e.status === 401) {
    showError("Unauthorized (401)", `${e.message}\nThis rayd needs a token: enter it in the Token field above.`, {
      retry: () => render({ user: true }),
    });
    tokenInput.focus();
    return;
  }
  // a scene error: find its line
  let line = 0,
    offset = -1,
    where = "";
  if (e.line) {
    line = e.line;
    offset = offsetOfLine(text, e.line, e.column || 1);
    where = `line ${e.line}, column ${e.column}`;
  } else if (e.path !== undefined && e.path !== null) {
    const d = parsed();
    if (d.root && d.text === text) {
      offset = pointerOffset(d.root, e.path);
      line = lineOf(text, offset);
    }
    where = `${e.path || "/"}${line ? ` (line ${line})` : ""}`;
  }
  showError(`${e.status} ${e.code}`, (where ? where + ": " : "") + e.message, { line, offset });
}

$("retry").addEventListener("click", () => retryAction && retryAction());
$("goto").addEventListener("click", () => gotoOffset >= 0 && editor.reveal(gotoOffset));

// ---- rendering -------------------------------------------------------------------
let gen = 0;
let lastRendered = null; // {id, text} of the last finished render
let partial = false; // the canvas holds a render stopped part way (its PNG says so)
const pageStart = 0; // performance.now() at navigation start

// user: started by the user (Render, Ctrl+Enter, Retry, an example): the
// only renders a scene from a link may have.
async function render({ fromStart = false, user = false } = {}) {
  if (linkWaiting) {
    if (!user) {
      showLinkWait();
      return;
    }
    linkDone(true);
  }
  const my = ++gen;
  const text = editor.value;
  const d = parsed();
  clearError();
  setState("rendering");
  partial = false;
  $("dl-png").disabled = true;
  $("raw").disabled = true; // until a denoised pass is shown
  $("link").hidden = true;
  bar(0);
  startClock(my);
  stats.passes = [];
  const started = fromStart ? pageStart : performance.now();
  try {
    const info = await renderer.full(unfold(text), sceneOf(d), (p) => {
      if (gen !== my) return;
      if (p.phase === "preview") {
        stats.lastPreviewMs = performance.now() - started;
        if (!lastProgress.total) bar(0.04);
      } else if (p.phase === "pass") {
        $("raw").disabled = !p.denoised;
        if (!stats.passes.length) stats.firstPassMs = performance.now() - started;
        stats.passes.push({ samples: p.samples, ms: performance.now() - started });
        lastProgress = { done: p.done, total: p.total, samples: p.samples };
        // the sample work done: the last pass is about half of it, so
        // passes done / passes would sit near the end for half the time
        bar(typeof p.progress === "number" ? p.progress : p.done / p.total);
        status("Refining · " + progressText(false));
      } else {
        lastProgress = { done: p.done, total: p.total };
        bar(0.04 + (0.96 * p.done) / p.total);
      }
    });
    if (gen !== my) return;
    doneAt = performance.now();
    stats.lastFullMs = doneAt - started;
    raysNow = (await api.raysTotal()) ?? raysNow;
    if (gen !== my) return;
    stopClock();
    stats.renders++;
    lastRendered = { id: info.id, text };
    status(`Done · ${progressText(true)}`);
    $("dl-png").disabled = false;
    $("link").hidden = false;
    $("link").textContent = `#${info.id.slice(0, 10)}`;
    $("link").href = await linkFor(info.id, unfold(text));
    if (gen !== my) return;
    document.body.dataset.renders = String(stats.renders);
    setState("done");
  } catch (e) {
    if (gen !== my || isAbort(e)) return;
    reportError(e, text);
  }
}

// Stop: the render in flight (its fetches aborted, a progressive job
// deleted, so rayd stops its work) and any full render still to come.  The
// image stays as far as it got, and once a tile or a pass is in it, the
// PNG button saves it (as NAME-partial.png).
function stop() {
  const was = document.body.dataset.state;
  if (!(was === "rendering" || was === "orbit")) return;
  partial = was === "rendering" && lastProgress.done > 0;
  $("dl-png").disabled = !partial;
  gen++;
  clearTimeout(fullTimer);
  clearTimeout(autoTimer);
  renderer.cancel();
  stopClock();
  setState("stopped");
  status("Stopped · " + progressText(false));
}
$("stop").addEventListener("click", () => stop());

// ---- camera: orbit by drag, dolly by wheel ------------------------------------------
// The moves of one drag, or of one burst of wheel turns or keys (until the
// full render that follows them), are one step of the undo history.
let drag = null;
let previewing = false;
let previewWanted = false;
let fullTimer = 0;
let moveRun = 0;

// fn(cam, floor) gives the new position; floor is the lowest height the eye
// may reach (ground.js), -Infinity when going under is allowed.
function moveCamera(fn, under = false) {
  if (linkWaiting) return false; // a gesture on a scene not drawn yet renders nothing
  const d = parsed();
  if (!d.root) return false;
  const cam = cameraOf(d.root.value);
  if (!cam) return false;
  const pos = fn(cam, under || $("under").checked ? -Infinity : eyeFloor(d.root.value, cam));
  let text;
  try {
    text = replaceAt(d.text, d.root, ["camera", "position"], fmtVector(pos));
  } catch (_) {
    return false;
  }
  editor.set(text, { keep: true, kind: "camera", group: "move" + moveRun });
  return true;
}

async function previewLoop() {
  if (previewing) {
    previewWanted = true;
    return;
  }
  previewing = true;
  const my = ++gen; // a full render in flight is superseded
  $("dl-png").disabled = true;
  $("link").hidden = true;
  stopClock();
  clearError();
  setState("orbit");
  try {
    do {
      previewWanted = false;
      if (gen !== my) break; // a full render started (release): it wins
      const d = parsed();
      if (!d.root) break;
      const size = sizeOf(d.root.value);
      if (!size) break;
      const t = performance.now();
      await renderer.preview(sceneOf(d), size);
      const ms = performance.now() - t;
      stats.previewFrames++;
      stats.previewMs.push(ms);
      if (stats.previewMs.length > 2000) stats.previewMs.shift();
      status(`Moving camera · preview ${fmtMs(ms)} (${(1000 / ms).toFixed(0)} fps)`);
    } while (previewWanted);
  } catch (e) {
    if (!isAbort(e)) reportError(e, editor.value);
  } finally {
    previewing = false;
  }
}

function scheduleFull(ms) {
  clearTimeout(fullTimer);
  fullTimer = setTimeout(() => {
    if (drag) return;
    moveRun++;
    render();
  }, ms);
}

canvas.addEventListener("pointerdown", (e) => {
  if (e.button !== 0 || linkWaiting) return;
  const d = parsed();
  const cam = d.root && cameraOf(d.root.value);
  if (!cam) return;
  moveRun++;
  drag = { x: e.clientX, y: e.clientY, cam, floor: eyeFloor(d.root.value, cam), moved: false, id: e.pointerId };
  canvas.setPointerCapture(e.pointerId);
  canvas.classList.add("dragging");
  e.preventDefault();
});
canvas.addEventListener("pointermove", (e) => {
  if (!drag || e.pointerId !== drag.id) return;
  const scale = Math.PI / Math.max(200, canvas.clientWidth); // a full width turns 180 degrees
  const dx = (e.clientX - drag.x) * scale;
  const dy = (e.clientY - drag.y) * scale;
  if (!drag.moved && Math.abs(e.clientX - drag.x) + Math.abs(e.clientY - drag.y) < 2) return;
  drag.moved = true;
  const { cam, floor } = drag;
  const under = e.shiftKey || $("under").checked;
  if (moveCamera(() => orbit(cam, dx, dy, under ? -Infinity : floor), under)) previewLoop();
});
function endDrag(e) {
  if (!drag || e.pointerId !== drag.id) return;
  const moved = drag.moved;
  drag = null;
  canvas.classList.remove("dragging");
  if (moved) scheduleFull(0);
}
canvas.addEventListener("pointerup", endDrag);
canvas.addEventListener("pointercancel", endDrag);
canvas.addEventListener(
  "wheel",
  (e) => {
    e.preventDefault();
    const dy = e.deltaMode === 1 ? e.deltaY * 16 : e.deltaY;
    if (moveCamera((cam, floor) => dolly(cam, Math.exp(dy * 0.0015), floor), e.shiftKey)) {
      previewLoop();
      scheduleFull(350);
    }
  },
  { passive: false }
);
canvas.addEventListener("keydown", (e) => {
  const step = Math.PI / 36;
  const moves = { ArrowLeft: [-step, 0], ArrowRight: [step, 0], ArrowUp: [0, -step], ArrowDown: [0, step] };
  let ok = false;
  if (moves[e.key]) ok = moveCamera((cam, floor) => orbit(cam, ...moves[e.key], floor), e.shiftKey);
  else if (e.key === "+" || e.key === "=") ok = moveCamera((cam, floor) => dolly(cam, 0.9, floor));
  else if (e.key === "-") ok = moveCamera((cam, floor) => dolly(cam, 1 / 0.9, floor));
  else return;
  e.preventDefault();
  if (ok) {
    previewLoop();
    scheduleFull(350);
  }
});

// ---- editing, examples, keys ---------------------------------------------------------
// Every change of the text is described and saved.  Typed, it renders
// 0.7 s later when auto is on; undone or redone, a camera move, an example
// or a link renders at once (the image follows the text), typing as typed.
let autoTimer = 0;
const rendersWhenUndone = new Set(["camera", "example", "link", "model"]);
editor.onChange(({ source, kind }) => {
  describe();
  hideNotice();
  if (kind === "link" && (source === "undo" || source === "redo")) {
    // undone, the text is the user's again; redone, the link's, which
    // waits again unless the user rendered it in this page already
    if (source === "undo") linkDone();
    else if (!accepted.has(editor.value)) linkWait();
  }
  autosave();
  if (source === "undo" || source === "redo") {
    select.value = editor.label;
    if (rendersWhenUndone.has(kind)) {
      render();
      return;
    }
  }
  if (source !== "set" && $("auto").checked) {
    clearTimeout(autoTimer);
    autoTimer = setTimeout(() => render(), 700);
  }
});

// "Example loaded -- Ctrl+Z to get your scene back", with an Undo button;
// gone at the next change.
function showNotice(text) {
  $("notice-text").textContent = text;
  $("notice").hidden = false;
}
function hideNotice() {
  $("notice").hidden = true;
}
$("notice-undo").addEventListener("click", () => editor.undo());
$("auto").checked = localStorage.getItem("rayd.auto") === "1";
$("auto").addEventListener("change", () => localStorage.setItem("rayd.auto", $("auto").checked ? "1" : "0"));
$("render").addEventListener("click", () => render({ user: true }));
// Denoise: path-traced renders refine denoised; a change renders again.
// Raw: the denoised pass shown, or its raw image, redrawn without a render.
$("denoise").checked = localStorage.getItem("rayd.denoise") === "1";
renderer.denoise = $("denoise").checked;
$("denoise").addEventListener("change", () => {
  renderer.denoise = $("denoise").checked;
  localStorage.setItem("rayd.denoise", renderer.denoise ? "1" : "0");
  render({ user: true });
});
function toggleRaw() {
  if ($("raw").disabled) return;
  const on = $("raw").getAttribute("aria-pressed") !== "true";
  $("raw").setAttribute("aria-pressed", String(on));
  renderer.setRaw(on).then(() => (document.body.dataset.raw = on ? "1" : "0"));
}
$("raw").addEventListener("click", toggleRaw);
$("linknote-render").addEventListener("click", () => render({ user: true }));
// Keys of the whole page; outside the text fields, Ctrl+Z and Ctrl+Y undo
// and redo the editor too (after a drag the focus is on the image), 1
// toggles the 1:1 view and R a denoised pass's raw image.
document.addEventListener("keydown", (e) => {
  if (e.key === "Enter" && (e.ctrlKey || e.metaKey)) {
    e.preventDefault();
    render({ user: true });
    return;
  }
  if (e.key === "Escape") {
    stop();
    return;
  }
  const t = e.target;
  if (e.defaultPrevented || t.isContentEditable || ["INPUT", "TEXTAREA", "SELECT"].includes(t.tagName)) return;
  const step = undoKey(e);
  if (step) {
    e.preventDefault();
    if (step === "undo") editor.undo();
    else editor.redo();
  } else if (e.key === "1" && !e.ctrlKey && !e.metaKey && !e.altKey) {
    e.preventDefault();
    view.toggle();
  } else if ((e.key === "r" || e.key === "R") && !e.ctrlKey && !e.metaKey && !e.altKey) {
    e.preventDefault();
    toggleRaw();
  }
});

// Generated examples with one value per line (spheres, cornell ...) are
// reflowed so that the editor shows them the way people write scenes.
function exampleText(ex) {
  const lines = ex.text.split("\n");
  const bare = lines.filter((l) => /^\s*[-+.\deE]+,?\s*$/.test(l)).length;
  if (bare < lines.length / 5) return ex.text;
  try {
    return format(JSON.parse(ex.text));
  } catch (_) {
    return ex.text;
  }
}

const select = $("example");
for (const ex of examples) {
  const o = document.createElement("option");
  o.value = ex.name;
  o.textContent = ex.name;
  select.appendChild(o);
}
const custom = document.createElement("option");
custom.value = "";
custom.textContent = "(from link)";
custom.hidden = true;
select.appendChild(custom);

// Is text exactly one of the examples?  If not, it is someone's work, and
// replacing it says how to get it back.
const exampleTexts = new Set(examples.map(exampleText));
const isExample = (text) => exampleTexts.has(text);

// editor.label is the menu's example, kept with each step of the history
// (an undo shows the example the text came from) and in the autosave.
function loadExample(name) {
  const ex = examples.find((x) => x.name === name) || examples[0];
  linkDone(); // an example is the server's own scene, chosen by the user
  const edited = !isExample(editor.value);
  select.value = editor.label = ex.name;
  editor.set(exampleText(ex), { kind: "example" });
  if (edited) showNotice("Example loaded — Ctrl+Z to get your scene back");
}
function forgetLink() {
  if (location.hash) history.replaceState(null, "", location.pathname + location.search);
}
select.addEventListener("change", () => {
  if (!select.value) return;
  loadExample(select.value);
  forgetLink();
  render({ user: true });
});
// Reset: the example chosen in the menu as it was (the default one when the
// text came from a link); one undoable step like choosing it.
$("reset").addEventListener("click", () => {
  loadExample(select.value || DEFAULT_EXAMPLE);
  forgetLink();
  render({ user: true });
});

// ---- your own model: the Open button and a drop on the page ------------------------------
// The files are read and embedded in the scene (model.js, drop.js), checked
// against the server's --max-body (its /healthz says it) before anything is
// sent, and rendered; what the server finds wrong in a file comes back as
// any scene error, with its JSON Pointer and line.
let maxBody = null;
async function bodyLimit() {
  if (maxBody === null)
    try {
      const j = await (await fetch("healthz", { cache: "no-store" })).json();
      if (Number.isFinite(j.max_body) && j.max_body > 0) maxBody = j.max_body;
    } catch (_) {
      /* an older server: its 413 says the same after the attempt */
    }
  return maxBody;
}
async function openFiles(files) {
  const title = `Cannot open ${files.map((f) => f.name).join(", ")}`;
  let got;
  try {
    got = foldFiles(await readFiles(files));
  } catch (e) {
    showError(title, String(e.message || e));
    return;
  }
  const d = parsed();
  if (!d.root || !d.root.value || typeof d.root.value !== "object" || Array.isArray(d.root.value)) {
    showError(
      title,
      "the editor's scene is not a valid JSON object, so the model has nowhere to go: " +
        "fix it (or Reset), then open the file again"
    );
    return;
  }
  const size = sizeOf(d.root.value) || [640, 480];
  const { scene, framed, lit } = withModels(d.root.value, got, { example: isExample(d.text), size });
  const text = format(scene);
  const names = [...got.models.map((m) => m.name), ...(got.env ? [got.env.name] : [])];
  const bytes = utf8Length(unfold(text));
  const limit = await bodyLimit();
  window.rayd.lastOpen = { names, bytes, limit, framed, lit, ignored: got.ignored };
  if (limit && bytes > limit) {
    showError(`Too large for this server: ${names.join(", ")}`, tooLargeMessage(names, bytes, limit));
    return;
  }
  editor.set(text, { kind: "model" });
  const said = [`Opened ${names.join(", ")}`];
  if (framed) said.push("camera framed on it");
  if (lit) said.push("a default light added (the scene had none)");
  if (got.ignored.length) said.push(`ignored ${got.ignored.join(", ")}`);
  showNotice(said.join(" · ") + " — Ctrl+Z to get your scene back");
  render({ user: true });
}
$("open-file").accept = ACCEPT;
wireDrop($("open"), $("open-file"), (files) => openFiles(files));

// ---- downloads -----------------------------------------------------------------------
function download(blob, name) {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = name;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
}
const baseName = () => select.value || (lastRendered ? "scene-" + lastRendered.id.slice(0, 12) : "scene");
$("dl-png").addEventListener("click", () =>
  canvas.toBlob((b) => b && download(b, baseName() + (partial ? "-partial" : "") + ".png"), "image/png")
);
$("dl-json").addEventListener("click", () =>
  download(new Blob([unfold(editor.value)], { type: "application/json" }), baseName() + ".json")
);

// ---- a link's scene: loaded, shown, not rendered ----------------------------------------------
// A link is anyone's to make, and anyone's page can open it (a tab, a
// window; a frame too, where the headers of api_web.c do not stop it), so
// the scene it carries is not the user's choice until the user says so:
// rendering it at once sent the user's token with a stranger's scene (and
// a scene can cost minutes of the server's work).  It is loaded into the
// editor and waits, with a note, for Render (the button, the note's, or
// Ctrl+Enter).  Until then nothing renders by itself: not at the start, not
// after an edit with auto ticked, not on an undo or redo, not on a camera
// gesture; the text is saved with linked: true, so a reload waits as well.
// A scene the user rendered is theirs for this page (accepted): redoing
// back to it does not ask again.
let linkWaiting = false;
const accepted = new Set();
// A text with folded strings is saved unfolded (megabytes), so once the
// changes stop for a moment rather than at each step of a camera drag.
let saveTimer = 0;
function autosave() {
  clearTimeout(saveTimer);
  const now = () => save(unfold(editor.value), editor.label, !isExample(editor.value), linkWaiting);
  if (unfold(editor.value) === editor.value) now();
  else saveTimer = setTimeout(now, 400);
}
function showLinkWait() {
  clearError();
  $("linknote").hidden = false;
  setState("linked");
  status("Scene from a link · not rendered: press Render to draw it");
}
function linkWait() {
  gen++; // a render of the scene before it ends here
  clearTimeout(fullTimer);
  clearTimeout(autoTimer);
  renderer.cancel();
  stopClock();
  $("dl-png").disabled = true; // the image is not the editor's scene
  $("link").hidden = true;
  bar(0);
  linkWaiting = true;
  autosave();
  showLinkWait();
}
// accept: the user renders the scene (it is theirs now); else it was
// replaced (an example, an undo).
function linkDone(accept = false) {
  if (!linkWaiting) return;
  linkWaiting = false;
  if (accept) accepted.add(editor.value);
  $("linknote").hidden = true;
  autosave();
}

// ---- start: a scene from the link, or the default example ----------------------------------
// "opened" (the link's scene is in the editor, waiting for Render), "same"
// (a hash change to a link of the text the editor holds, as when the user
// clicks the page's own link: nothing changes), "none" (no scene in the
// link) or "bad" (it could not be decoded: the error is shown, and no
// render may follow, or it would clear the error and show another scene
// as if it were the link's).  Opening the page, a link always waits, even
// for the text saved from the last visit.
async function openHash(atStart = false) {
  let got = null;
  try {
    got = await fromHash(location.hash);
  } catch (e) {
    showError(
      "Bad link",
      "the scene in this link could not be opened: " +
        (e.message || e) +
        "\nThe editor holds your last scene instead; Render draws it."
    );
    return "bad";
  }
  if (!got) return "none";
  if (got.text === unfold(editor.value)) {
    if (!atStart) return "same";
    linkWait();
    return "opened";
  }
  const edited = !isExample(editor.value);
  linkWaiting = true; // before the change, so that the autosave says so
  select.value = editor.label = "";
  editor.set(fold(got.text), { kind: "link" });
  if (edited) showNotice("Link opened — Ctrl+Z to get your scene back");
  linkWait();
  return "opened";
}
window.addEventListener("hashchange", () => openHash());

// The text of the last visit (autosave.js), or the default example; then
// the link's scene over it, undoably, so a link never costs the saved work.
(async () => {
  const saved = loadSaved();
  linkWaiting = !!(saved && saved.linked); // the saved text is a link's, never rendered
  const known = (name) => examples.some((x) => x.name === name);
  if (saved && (saved.edited || !known(saved.example))) {
    editor.label = known(saved.example) ? saved.example : "";
    editor.reset(fold(saved.text));
  } else if (saved) {
    editor.label = saved.example;
    editor.reset(exampleText(examples.find((x) => x.name === saved.example)));
  } else {
    editor.label = DEFAULT_EXAMPLE;
    editor.reset(exampleText(examples.find((x) => x.name === DEFAULT_EXAMPLE) || examples[0]));
  }
  select.value = editor.label;
  describe();
  const link = await openHash(true);
  if (link === "bad" || link === "opened") return;
  if (linkWaiting) linkWait();
  else render({ fromStart: true });
})();
