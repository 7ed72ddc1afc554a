// preview.mjs URL -- drives the preview page of the rayd at URL in Debian's
// Chromium (headless, a fresh profile) and prints one "PASS name" or
// "FAIL name: why" line per case.  Run by preview.sh, which starts rayd.
//
// Pixels are compared exactly: the canvas (read back as a lossless PNG) and
// the PNG of POST /v1/render for the editor's text are decoded by pngcmp
// (libpng, through the core's rayd_png_decode) and must be equal.
import { cases } from "./cases.mjs";
import { launch } from "./chromium.mjs";
import { execFileSync } from "node:child_process";
import { createHash } from "node:crypto";
import { mkdtempSync, writeFileSync, mkdirSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

const URL = process.argv[2];
const OUT_DIR = process.env.OUT_DIR || "build";
const PNGCMP = process.env.PNGCMP;
const WORK = process.env.WORK || mkdtempSync(join(tmpdir(), "rayd-browser-"));
const MEASURE = process.env.MEASURE === "1";
const { pass, fail, check, failed } = cases("renders_on_open");

async function post(path, body) {
  const res = await fetch(URL + path, { method: "POST", headers: { "Content-Type": "application/json" }, body });
  return { status: res.status, bytes: Buffer.from(await res.arrayBuffer()) };
}
// rayd runs with --test-gate: the test decides when held work may go on
async function gate(tiles) {
  return (await fetch(URL + "/v1/test/gate?tiles=" + tiles, { method: "POST" })).json();
}
async function gateState() {
  return (await fetch(URL + "/v1/test/gate")).json();
}
// polls cond() every 50 ms until it holds; false after ms (a bound that only
// ends a hung case)
async function until(cond, ms) {
  const end = Date.now() + ms;
  while (!(await cond())) {
    if (Date.now() > end) return false;
    await new Promise((r) => setTimeout(r, 50));
  }
  return true;
}
// Job id's state once it is canceled or forgotten ("gone"), or its state
// after 60 s of waiting for that.
async function jobEnded(id) {
  let state = "";
  await until(async () => {
    const r = await fetch(`${URL}/v1/jobs/${id}`);
    state = r.status === 404 ? "gone" : (await r.json()).state;
    return state === "canceled" || state === "gone";
  }, 60000);
  return state;
}
async function metric(name) {
  const t = await (await fetch(URL + "/metrics")).text();
  const line = t.split("\n").find((l) => l.startsWith(name + " "));
  return line ? Number(line.split(" ")[1]) : NaN;
}

// The canvas as a PNG file, and the server's PNG of the editor's text.
let seq = 0;
async function canvasPng(page) {
  const url = await page.evaluate(() => document.getElementById("canvas").toDataURL("image/png"));
  const f = join(WORK, `canvas-${++seq}.png`);
  writeFileSync(f, Buffer.from(url.split(",")[1], "base64"));
  return f;
}
async function serverPng(text) {
  const r = await post("/v1/render", text);
  if (r.status !== 200) throw new Error(`POST /v1/render answered ${r.status}: ${r.bytes.toString().slice(0, 200)}`);
  const f = join(WORK, `server-${++seq}.png`);
  writeFileSync(f, r.bytes);
  return f;
}
function samePixels(a, b) {
  try {
    execFileSync(PNGCMP, [a, b], { stdio: ["ignore", "ignore", "pipe"] });
    return true;
  } catch (e) {
    return (e.stderr && e.stderr.toString().trim()) || `pngcmp exit ${e.status}`;
  }
}
async function canvasEqualsServer(page) {
  const text = await page.evaluate(() => window.rayd.editor.value);
  return samePixels(await serverPng(text), await canvasPng(page));
}

const renders = (page) => page.evaluate(() => Number(document.body.dataset.renders || 0));
async function waitDone(page, after, timeout = 120000) {
  await page.waitForFunction(
    (n) => document.body.dataset.state === "done" && Number(document.body.dataset.renders || 0) > n,
    after,
    { timeout }
  );
}
async function waitState(page, state, timeout = 60000) {
  await page.waitForFunction((s) => document.body.dataset.state === s, state, { timeout });
}
const setText = (page, text) =>
  page.evaluate((t) => {
    window.rayd.editor.set(t);
    document.getElementById("scene").dispatchEvent(new Event("input"));
  }, text);

// A link to text as another site would make it: #scene=<sha256>&j=<base64url>.
const linkOf = (text) =>
  `#scene=${createHash("sha256").update(text).digest("hex")}&j=${Buffer.from(text).toString("base64url")}`;
// The requests page p (frames included) makes to rayd's API, as "METHOD
// /path": what carries the token.  The page's own files are not counted.
function apiRequests(p) {
  const seen = [];
  p.on("request", (r) => {
    const u = new globalThis.URL(r.url());
    if (u.origin === new globalThis.URL(URL).origin && /^\/(v1\/|metrics)/.test(u.pathname))
      seen.push(`${r.method()} ${u.pathname}`);
  });
  return seen;
}
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// the first line of text containing needle (1-based)
const lineWith = (text, needle) => text.split("\n").findIndex((l) => l.includes(needle)) + 1;

const { context, close } = await launch(fail, { viewport: { width: 1440, height: 860 } });
// Every Content-Security-Policy violation of every page (rayd serves the
// page with a CSP: nothing of it may be refused), reported to Node.
const cspViolations = [];
await context.exposeBinding("raydCspViolation", (src, v) => cspViolations.push(v));
await context.addInitScript(() =>
  document.addEventListener("securitypolicyviolation", (e) =>
    window.raydCspViolation(`${e.violatedDirective} blocked ${e.blockedURI || "inline"} at ${e.sourceFile}:${e.lineNumber}`)
  )
);

try {
  const page = context.pages()[0] || (await context.newPage());
  const consoleErrors = [];
  page.on("console", (m) => {
    if (m.type() === "error" || m.type() === "warning") consoleErrors.push(`${m.type()}: ${m.text()}`);
  });
  page.on("pageerror", (e) => consoleErrors.push("pageerror: " + e.message));

  // --- the page opens and renders its example with no click ---------------------------
  const t0 = Date.now();
  await page.goto(URL + "/", { waitUntil: "load" });
  let opened = false;
  await check("renders_on_open", async () => {
    await page.waitForFunction(() => window.rayd && window.rayd.stats, null, { timeout: 60000 });
    await waitDone(page, 0, 60000);
    opened = true;
  });
  if (!opened) {
    // nothing else can work: say why and stop, rather than time out case after case
    fail("page_broken", consoleErrors.join(" | ") || "no error in the console");
    throw new Error("the page did not render its example; the other cases were not run");
  }
  const openMs = Date.now() - t0;
  await check("no_console_errors", () => (consoleErrors.length ? consoleErrors.join(" | ") : true));
  await check("example_menu", async () => {
    const opts = await page.$$eval("#example option:not([hidden])", (o) => o.map((x) => x.value));
    for (const n of ["paper", "whitted", "spheres", "cornell", "gltf"]) if (!opts.includes(n)) return `no ${n} in ${opts}`;
    const v = await page.$eval("#example", (s) => s.value);
    return v === "whitted" || `selected ${v}`;
  });
  await check("example_pixels_equal_post_render", () => canvasEqualsServer(page));
  await check("quick_pass_then_tiles", async () => {
    const s = await page.evaluate(() => ({ ...window.rayd.stats, status: document.getElementById("status").textContent }));
    if (!(s.lastPreviewMs > 0)) return "no quick pass drawn";
    if (!(s.lastPreviewMs <= s.lastFullMs)) return `quick pass at ${s.lastPreviewMs} ms after the full at ${s.lastFullMs}`;
    return /^Done · \d+\/\d+ tiles · .*(rays\/s|from cache) · [\d.]+ m?s$/.test(s.status) || `status "${s.status}"`;
  });
  await check("screenshot", async () => {
    await page.mouse.move(5, 5);
    const f = join(OUT_DIR, "preview.png");
    mkdirSync(OUT_DIR, { recursive: true });
    await page.screenshot({ path: f });
  });

  // --- another example from the menu, by Ctrl+Enter too ---------------------------------
  // the glTF example first: an embedded .glb, its own camera and lights, drawn by the page
  // as the server draws it (paper, next, is the scene the later cases start from)
  await check("menu_gltf_pixels_equal", async () => {
    const n = await renders(page);
    await page.selectOption("#example", "gltf");
    await waitDone(page, n);
    const text = await page.evaluate(() => window.rayd.editor.value);
    if (!text.includes('"type": "gltf"')) return "editor does not hold gltf.json";
    return canvasEqualsServer(page);
  });
  await check("menu_paper_pixels_equal", async () => {
    const n = await renders(page);
    await page.selectOption("#example", "paper");
    await waitDone(page, n);
    const text = await page.evaluate(() => window.rayd.editor.value);
    if (!text.includes('"position": [0, 1.5, 6]')) return "editor does not hold paper.json";
    return canvasEqualsServer(page);
  });
  await check("ctrl_enter_renders", async () => {
    const n = await renders(page);
    await page.focus("#scene");
    await page.keyboard.press("Control+Enter");
    await waitDone(page, n);
  });

  await check("auto_render_after_edit", async () => {
    const n = await renders(page);
    await page.check("#auto");
    await page.focus("#scene");
    await page.keyboard.type(" "); // at the caret (the start): still the same scene
    await waitDone(page, n);
    await page.uncheck("#auto");
  });

  // --- a scene error at its line, malformed JSON at its line ----------------------------------
  const paper = await page.evaluate(() => window.rayd.editor.value);
  await check("scene_error_line", async () => {
    const bad = paper.replace('"radius": 0.7', '"radius": -0.7');
    if (bad === paper) return "could not make the bad scene";
    await setText(page, bad);
    await page.click("#render");
    await waitState(page, "error");
    const want = lineWith(bad, '"radius": -0.7');
    const got = await page.$eval("#editor", (e) => Number(e.dataset.errorLine));
    const msg = await page.$eval("#error", (e) => (e.hidden ? "" : e.textContent));
    const gutter = await page.$eval(".gutter .err", (e) => Number(e.textContent));
    if (!msg.includes("/objects/2/radius")) return `message "${msg}"`;
    if (!msg.includes(`line ${want}`)) return `message "${msg}" does not name line ${want}`;
    return (got === want && gutter === want) || `highlighted line ${got} (gutter ${gutter}), want ${want}`;
  });
  await check("malformed_json_line", async () => {
    const lines = paper.split("\n");
    const k = lineWith(paper, '"lights"'); // drop the comma at the end of the line before
    lines[k - 2] = lines[k - 2].replace(/,\s*$/, "");
    await setText(page, lines.join("\n"));
    await page.click("#render");
    await waitState(page, "error");
    const got = await page.$eval("#editor", (e) => Number(e.dataset.errorLine));
    const msg = await page.$eval("#error .error-msg", (e) => e.textContent);
    return (got === k && msg.includes(`line ${k}`)) || `highlighted line ${got}, message "${msg}", want line ${k}`;
  });
  // "Show in editor" brings the error's column into view too: the editor
  // does not wrap, and it used to scroll only vertically.
  await check("show_in_editor_reveals_column", async () => {
    const far = '"material": "red", ' + " ".repeat(150) + '"radiuss": 1';
    const bad = paper.replace('"material": "red"', far);
    if (bad === paper) return "could not make the bad scene";
    await setText(page, bad);
    await page.click("#render");
    await waitState(page, "error");
    await page.$eval("#scene", (t) => (t.scrollLeft = 0));
    await page.click("#goto");
    const g = await page.$eval("#scene", (t) => {
      const before = t.value.slice(0, t.selectionStart);
      const col = t.selectionStart - before.lastIndexOf("\n") - 1;
      const c = document.createElement("canvas").getContext("2d");
      const cs = getComputedStyle(t);
      c.font = `${cs.fontSize} ${cs.fontFamily}`;
      const x = parseFloat(cs.paddingLeft) + col * c.measureText("0").width - t.scrollLeft;
      return { col, x, width: t.clientWidth, at: t.value.slice(t.selectionStart, t.selectionStart + 9) };
    });
    if (g.at !== '"radiuss"') return `the caret is at "${g.at}", not at the unknown key`;
    return (g.x >= 0 && g.x <= g.width - 40) || `column ${g.col} is at x ${g.x} of a ${g.width} px editor (not in view)`;
  });
  await check("error_cleared_by_good_render", async () => {
    const n = await renders(page);
    await setText(page, paper);
    await page.click("#render");
    await waitDone(page, n);
    const hidden = await page.$eval("#error", (e) => e.hidden);
    const line = await page.$eval("#editor", (e) => e.dataset.errorLine);
    return (hidden && line === "0") || `error still shown (line ${line})`;
  });

  // --- 503 and network errors, with a retry --------------------------------------------
  await check("busy_503_retry", async () => {
    await page.route("**/v1/scenes", (r) =>
      r.fulfill({
        status: 503,
        headers: { "Retry-After": "1" },
        contentType: "application/json",
        body: '{"error":{"status":503,"code":"queue_full","message":"render queue is full"}}',
      })
    );
    await page.click("#render");
    await waitState(page, "error");
    const msg = await page.$eval("#error", (e) => e.textContent);
    const retry = await page.$eval("#retry", (e) => !e.hidden);
    if (!msg.includes("queue_full") || !retry) return `message "${msg}", retry shown: ${retry}`;
    await page.unroute("**/v1/scenes");
    const n = await renders(page);
    await page.click("#retry");
    await waitDone(page, n);
  });
  await check("network_error_retry", async () => {
    await page.route("**/v1/**", (r) => r.abort("connectionrefused"));
    await page.click("#render");
    await waitState(page, "error");
    const msg = await page.$eval("#error", (e) => e.textContent);
    const retry = await page.$eval("#retry", (e) => !e.hidden);
    await page.unroute("**/v1/**");
    if (!/cannot reach the server/i.test(msg) || !retry) return `message "${msg}", retry shown: ${retry}`;
    const n = await renders(page);
    await page.click("#retry");
    await waitDone(page, n);
  });

  // --- orbit by drag: the camera in the text and the image change ---------------------------------
  await check("orbit_drag", async () => {
    const before = JSON.parse(await page.evaluate(() => window.rayd.editor.value));
    const imgBefore = await canvasPng(page);
    const box = await page.$eval("#canvas", (c) => {
      const r = c.getBoundingClientRect();
      return { x: r.x, y: r.y, w: r.width, h: r.height };
    });
    const frames0 = await page.evaluate(() => window.rayd.stats.previewFrames);
    const n = await renders(page);
    const cx = box.x + box.w / 2,
      cy = box.y + box.h / 2;
    await page.mouse.move(cx, cy);
    await page.mouse.down();
    for (let k = 1; k <= 12; k++) {
      await page.mouse.move(cx + k * 12, cy + k * 3);
      await page.waitForTimeout(25);
    }
    await page.waitForFunction((f) => window.rayd.stats.previewFrames > f, frames0, { timeout: 60000 });
    const during = await page.evaluate(() => document.body.dataset.state);
    await page.mouse.up();
    await waitDone(page, n);
    const after = JSON.parse(await page.evaluate(() => window.rayd.editor.value));
    const p0 = before.camera.position,
      p1 = after.camera.position,
      f = before.camera.look_at;
    const dist = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    if (during !== "orbit") return `state while dragging was ${during}`;
    if (dist(p0, p1) < 0.1) return `camera did not move: ${p0} -> ${p1}`;
    if (dist(after.camera.look_at, f) > 1e-9) return "look_at moved";
    if (Math.abs(dist(p0, f) - dist(p1, f)) > 1e-3) return `distance to look_at changed ${dist(p0, f)} -> ${dist(p1, f)}`;
    if (JSON.stringify({ ...after, camera: null }) !== JSON.stringify({ ...before, camera: null }))
      return "something else than the camera changed";
    const imgAfter = await canvasPng(page);
    if (samePixels(imgBefore, imgAfter) === true) return "the image did not change";
    return canvasEqualsServer(page);
  });
  await check("wheel_dolly", async () => {
    const before = JSON.parse(await page.evaluate(() => window.rayd.editor.value)).camera;
    const n = await renders(page);
    const box = await page.$eval("#canvas", (c) => c.getBoundingClientRect().toJSON());
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    await page.mouse.wheel(0, -200);
    await waitDone(page, n);
    const after = JSON.parse(await page.evaluate(() => window.rayd.editor.value)).camera;
    const dist = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    const d0 = dist(before.position, before.look_at),
      d1 = dist(after.position, after.look_at);
    return (d1 < d0 * 0.9 && d1 > d0 * 0.5) || `distance ${d0} -> ${d1}`;
  });

  // --- a new render cancels the one in flight, on the server too -------------------------------
  // The gate holds the first render's tiles, so it is still in flight when
  // the second one replaces it, however fast the machine.
  await check("new_render_cancels", async () => {
    const slow = JSON.parse(paper);
    slow.render = { ...slow.render, width: 1280, height: 720, samples: 4 };
    const gone0 = await metric('rayd_canceled_total{reason="client_gone"}');
    await gate(0);
    try {
      await setText(page, JSON.stringify(slow, null, 2));
      await page.click("#render");
      await page.waitForFunction(() => /0\/\d+ tiles/.test(document.getElementById("status").textContent), null, {
        timeout: 60000,
      });
      if (!(await until(async () => (await gateState()).queued > 0, 60000))) return "the render never reached the server";
      const n = await renders(page);
      await setText(page, paper);
      await page.click("#render");
      let gone1 = gone0;
      await until(async () => (gone1 = await metric('rayd_canceled_total{reason="client_gone"}')) > gone0, 60000);
      await gate("open");
      await waitDone(page, n);
      return gone1 > gone0 || `rayd_canceled_total{reason="client_gone"} stayed ${gone0}`;
    } finally {
      await gate("open");
    }
  });

  // --- a path-traced scene refines in place, each pass the plain render of its samples ------------
  // The gate lets through the quick pass and the first pass only, so the
  // page is seen between passes however fast the machine.  The image is
  // over 256x256 pixels, so the job is bulk work and the quick pass's two
  // tiles (interactive) are taken long before pass 1's twenty are done.
  // Were both the same class, the older task (the job, at times) would go
  // first (task.c: a client's oldest task), pass 2's first tile could take
  // the quick pass's place at the gate, and the page would wait for it.
  await check("path_refines_pass_by_pass", async () => {
    const { examples } = await import(join(OUT_DIR, "server/web/examples.js"));
    const sc = JSON.parse(examples.find((e) => e.name === "cornell").text);
    // 20 tiles a pass (64 pixels square); the quick pass 80x60 is 2 tiles
    sc.render = { ...sc.render, width: 320, height: 240, samples: 8 };
    const text = JSON.stringify(sc, null, 2);
    const n = await renders(page);
    await gate(0);
    let first, status, barAfterFirst;
    try {
      await setText(page, text);
      await page.click("#render");
      // the quick pass's task and the first pass's, both waiting at the gate
      if (!(await until(async () => (await gateState()).queued === 2, 60000))) return "the render never reached the server";
      await gate(2 + 20);
      await page.waitForFunction(() => window.rayd.stats.passes.length === 1, null, { timeout: 60000 });
      status = await page.$eval("#status", (e) => e.textContent);
      barAfterFirst = await page.$eval("#bar", (e) => parseFloat(e.style.width));
      first = await canvasPng(page);
    } finally {
      await gate("open");
    }
    await waitDone(page, n);
    if (!/^Refining · 1 spp · pass 1\/4/.test(status)) return `status after the first pass "${status}"`;
    // the bar shows the sample work (docs/api.md, the job's "progress"): the
    // one-sample pass, then 8 samples' worth for the rest (pass 2 renders 2,
    // passes 4 and 8 add to them), so 1/9 of it; not 1/4 for one pass of four
    if (!(Math.abs(barAfterFirst - 100 / 9) < 0.5)) return `progress bar at ${barAfterFirst}% after the first pass, want 11.1%`;
    const one = JSON.parse(text);
    one.render.samples = 1;
    const r1 = samePixels(await serverPng(JSON.stringify(one)), first);
    if (r1 !== true) return "first pass: " + r1;
    const got = await page.evaluate(() => window.rayd.stats.passes.map((p) => p.samples).join(","));
    if (!got.endsWith("8")) return `passes drawn: ${got}`;
    const done = await page.$eval("#status", (e) => e.textContent);
    if (!/^Done · 8 spp · pass 4\/4/.test(done)) return `status "${done}"`;
    return canvasEqualsServer(page);
  });

  // --- downloads and the link that reopens the scene ---------------------------------------
  await check("download_png_and_json", async () => {
    const [dp] = await Promise.all([page.waitForEvent("download"), page.click("#dl-png")]);
    const fpng = join(WORK, "download.png");
    await dp.saveAs(fpng);
    const [dj] = await Promise.all([page.waitForEvent("download"), page.click("#dl-json")]);
    const fjson = join(WORK, "download.json");
    await dj.saveAs(fjson);
    const text = await page.evaluate(() => window.rayd.editor.value);
    const { readFileSync } = await import("node:fs");
    if (readFileSync(fjson, "utf8") !== text) return "the JSON download is not the editor's text";
    return samePixels(await serverPng(text), fpng);
  });
  // The page's own link opens its scene in the editor, and the scene waits
  // for the user's Render: a link is anyone's (finding 9: a page elsewhere
  // opening or framing the preview with #scene= made it render that scene
  // with the user's token, with no click).  Nothing goes to the API until
  // Render, not even with auto ticked; then the pixels are the server's.
  await check("link_waits_for_render", async () => {
    const text = await page.evaluate(() => window.rayd.editor.value);
    const href = await page.$eval("#link", (a) => a.href);
    const id = (await post("/v1/scenes", text)).bytes.toString().match(/"id":"([0-9a-f]{64})"/);
    if (!id || !href.includes("#scene=" + id[1])) return `link ${href.slice(0, 120)} does not carry the id ${id && id[1]}`;
    await page.evaluate(() => localStorage.setItem("rayd.auto", "1"));
    const p2 = await context.newPage();
    try {
      const sent = apiRequests(p2);
      await p2.goto(href);
      await p2.waitForFunction(() => !["loading", ""].includes(document.body.dataset.state || ""), null, { timeout: 60000 });
      const state = await p2.evaluate(() => document.body.dataset.state);
      if (state !== "linked") return `the linked page went to "${state}" by itself (${sent.join(", ")})`;
      if ((await p2.evaluate(() => window.rayd.editor.value)) !== text) return "the editor does not hold the link's scene";
      const note = await p2.$eval("#linknote", (e) => (e.hidden ? "" : e.textContent.replace(/\s+/g, " ")));
      if (!/from a link: not rendered/.test(note)) return `note "${note}"`;
      if (!(await p2.$eval("#auto", (e) => e.checked))) return "auto is not ticked: the case proves less";
      // an edit (auto would render it 0.7 s later) and a camera gesture: still nothing sent
      await p2.focus("#scene");
      await p2.keyboard.press("Control+End");
      await p2.keyboard.type(" ");
      const box = await p2.$eval("#canvas", (c) => c.getBoundingClientRect().toJSON());
      await p2.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
      await p2.mouse.wheel(0, -200);
      await sleep(1500);
      if (sent.length) return `sent before Render: ${sent.join(", ")}`;
      if ((await p2.evaluate(() => document.body.dataset.state)) !== "linked") return "the page left the linked state by itself";
      await p2.click("#render");
      await waitDone(p2, 0);
      if (!sent.some((r) => r.startsWith("POST /v1/"))) return `Render sent no POST: ${sent.join(", ")}`;
      if (!(await p2.$eval("#linknote", (e) => e.hidden))) return "the note stays after Render";
      const text2 = await p2.evaluate(() => window.rayd.editor.value);
      if (text2 !== text + " ") return "the rendered text is not the link's with the edit";
      return samePixels(await serverPng(text2), await canvasPng(p2));
    } finally {
      await p2.close();
      await page.evaluate(() => localStorage.setItem("rayd.auto", "0"));
    }
  });

  // A link's scene left unrendered is saved as a link's: the page opened
  // again without the link (a reload, a new tab) still waits; once the user
  // rendered it, it is theirs and the next opening renders it.
  await check("linked_scene_waits_after_reopen", async () => {
    const sc = JSON.parse(await page.evaluate(() => window.rayd.editor.value));
    sc.render = { ...sc.render, width: 40, height: 30, seed: 91 };
    const text = JSON.stringify(sc, null, 2);
    const p2 = await context.newPage();
    try {
      const sent = apiRequests(p2);
      await p2.goto(URL + "/" + linkOf(text));
      await waitState(p2, "linked");
      await p2.goto(URL + "/");
      await waitState(p2, "linked");
      if ((await p2.evaluate(() => window.rayd.editor.value)) !== text) return "the reopened page lost the link's scene";
      await sleep(500);
      if (sent.length) return `sent before Render: ${sent.join(", ")}`;
      await p2.click("#linknote-render");
      await waitDone(p2, 0);
      await p2.reload();
      await waitDone(p2, 0);
      return (await p2.evaluate(() => window.rayd.editor.value)) === text || "the rendered scene did not come back";
    } finally {
      await p2.close();
    }
  });

  // A link pasted into an open page (a hash change, no reload) waits too,
  // and so does a redo back to it; the undo brings back the user's scene,
  // which renders as an undone example does.
  await check("hashchange_link_waits", async () => {
    const mine = await page.evaluate(() => window.rayd.editor.value);
    const sc = JSON.parse(mine);
    sc.render = { ...sc.render, width: 40, height: 30, seed: 92 };
    const text = JSON.stringify(sc, null, 2);
    const p2 = await context.newPage();
    try {
      await p2.goto(URL + "/");
      await waitDone(p2, 0);
      const before = await p2.evaluate(() => window.rayd.editor.value);
      const sent = apiRequests(p2);
      await p2.evaluate((h) => (location.hash = h), linkOf(text));
      await waitState(p2, "linked");
      if ((await p2.evaluate(() => window.rayd.editor.value)) !== text) return "the hash change did not load the link's scene";
      await sleep(500);
      if (sent.length) return `sent for the link: ${sent.join(", ")}`;
      let n = await renders(p2);
      await p2.focus("#canvas");
      await p2.keyboard.press("Control+z");
      await waitDone(p2, n);
      if ((await p2.evaluate(() => window.rayd.editor.value)) !== before) return "Ctrl+Z did not bring the scene back";
      sent.length = 0;
      await p2.keyboard.press("Control+Shift+z");
      await waitState(p2, "linked");
      await sleep(500);
      return sent.length === 0 || `sent after the redo to the link: ${sent.join(", ")}`;
    } finally {
      await p2.close();
    }
  });

  // rayd serves the page and its files with a policy that keeps other
  // sites out: no frame, nothing but its own files and its own server.
  await check("csp_headers", async () => {
    for (const path of ["/", "/index.html", "/app.js", "/app.css", "/examples.js", "/favicon.svg"]) {
      const res = await fetch(URL + path);
      if (res.status !== 200) return `${path}: ${res.status}`;
      const csp = res.headers.get("content-security-policy") || "";
      for (const d of ["default-src 'self'", "script-src 'self'", "style-src 'self'", "connect-src 'self'",
                       "frame-ancestors 'none'", "base-uri 'none'", "form-action 'none'", "object-src 'none'"])
        if (!csp.split(/\s*;\s*/).includes(d)) return `${path}: no "${d}" in Content-Security-Policy "${csp}"`;
      if (/unsafe-inline|unsafe-eval/.test(csp)) return `${path}: ${csp}`;
      const want = { "x-frame-options": "DENY", "referrer-policy": "no-referrer", "cross-origin-opener-policy": "same-origin" };
      for (const [h, v] of Object.entries(want))
        if (res.headers.get(h) !== v) return `${path}: ${h}: ${res.headers.get(h)}`;
    }
  });

  // A page of another origin (python's http.server on another port) that
  // frames the preview with a #scene= link: the browser refuses the frame,
  // so nothing of the preview runs there and nothing is sent to the API.
  if (process.env.FRAMER_URL)
    await check("framed_preview_blocked", async () => {
      const text = await page.evaluate(() => window.rayd.editor.value);
      const target = URL + "/" + linkOf(text);
      writeFileSync(
        join(process.env.FRAMER_DIR, "frame.html"),
        `<!doctype html><title>framer</title><iframe id="f" src="${target}" width="800" height="600"` +
          ` onload="document.title = 'loaded'"></iframe>`
      );
      const p3 = await context.newPage();
      try {
        const sent = apiRequests(p3);
        let frameHeaders = null;
        p3.on("response", (r) => {
          if (r.url().startsWith(URL + "/") && r.request().resourceType() === "document") frameHeaders = r.headers();
        });
        await p3.goto(process.env.FRAMER_URL + "/frame.html");
        await p3.waitForFunction(() => document.title === "loaded", null, { timeout: 60000 });
        await sleep(1000);
        // a refused frame shows the browser's error page (chrome-error://), not the preview
        const child = p3.frames().find((f) => f !== p3.mainFrame());
        const childUrl = child ? child.url() : "(none)";
        if (sent.length) return `the framed preview sent ${sent.join(", ")}`;
        if (childUrl.startsWith(URL)) {
          const state = await child.evaluate(() => document.body && document.body.dataset.state).catch((e) => e.message);
          return `the preview loaded in the frame (state ${state}, ${childUrl.slice(0, 80)})`;
        }
        if (!frameHeaders) return "the frame's request never reached rayd";
        return frameHeaders["x-frame-options"] === "DENY" || `X-Frame-Options: ${frameHeaders["x-frame-options"]}`;
      } finally {
        await p3.close();
      }
    });

  // A link cut short (a chat client, a copy that missed its end) is said
  // so and stays said: the page used to show "Bad link", then render the
  // saved scene at once, which cleared the message, so the wrong scene
  // looked like the link's.
  await check("bad_link_error_stays", async () => {
    const href = await page.$eval("#link", (a) => a.href);
    const p2 = await context.newPage();
    try {
      await p2.goto(href.slice(0, href.length - 40));
      await p2.waitForFunction(() => ["done", "error"].includes(document.body.dataset.state), null, { timeout: 60000 });
      const state = await p2.evaluate(() => document.body.dataset.state);
      const title = await p2.$eval("#error", (e) => (e.hidden ? "" : e.querySelector(".error-title").textContent));
      const renders2 = await p2.evaluate(() => document.body.dataset.renders || "0");
      return (state === "error" && title === "Bad link" && renders2 === "0") ||
        `state ${state}, error "${title}", ${renders2} renders: the broken link's error did not stay`;
    } finally {
      await p2.close();
    }
  });

  // A link whose id does not name its text (edited by hand, or two links
  // spliced) is refused with the reason, in words, not the browser's.
  await check("altered_link_refused", async () => {
    const href = await page.$eval("#link", (a) => a.href);
    const bad = href.replace(/#scene=([0-9a-f]{63})([0-9a-f])/, (m, a, b) => `#scene=${a}${b === "0" ? "1" : "0"}`);
    if (bad === href) return `no scene id in ${href.slice(0, 120)}`;
    const p2 = await context.newPage();
    try {
      await p2.goto(bad);
      await p2.waitForFunction(() => ["done", "error"].includes(document.body.dataset.state), null, { timeout: 60000 });
      const title = await p2.$eval("#error", (e) => (e.hidden ? "" : e.querySelector(".error-title").textContent));
      const text = await p2.$eval("#error", (e) => e.textContent);
      return (title === "Bad link" && /not the one its id names/.test(text) && !/Failed to execute/.test(text)) ||
        `error "${title}": ${text.slice(0, 200)}`;
    } finally {
      await p2.close();
    }
  });

  // --- the page keeps work: undo of camera moves and examples, autosave, reset -----------------
  const { examples: EXAMPLES } = await import(join(OUT_DIR, "server/web/examples.js"));
  const exampleOf = (name) => EXAMPLES.find((e) => e.name === name).text;
  const editorText = () => page.evaluate(() => window.rayd.editor.value);
  const canvasBox = () =>
    page.$eval("#canvas", (c) => {
      const r = c.getBoundingClientRect();
      return { x: r.x, y: r.y, w: r.width, h: r.height };
    });
  // a drag on the image from (x0, y0) by (dx, dy) css pixels, in steps
  async function drag(x0, y0, dx, dy, steps = 12) {
    await page.mouse.move(x0, y0);
    await page.mouse.down();
    for (let k = 1; k <= steps; k++) await page.mouse.move(x0 + (dx * k) / steps, y0 + (dy * k) / steps);
    await page.mouse.up();
  }
  async function showScene(text) {
    const n = await renders(page);
    await setText(page, text);
    await page.click("#render");
    await waitDone(page, n);
  }

  await check("undo_camera_move", async () => {
    await showScene(exampleOf("whitted"));
    const before = await editorText();
    const box = await canvasBox();
    let n = await renders(page);
    await drag(box.x + box.w / 2, box.y + box.h / 2, 150, 40);
    await waitDone(page, n);
    const moved = await editorText();
    if (moved === before) return "the drag did not move the camera";
    // one Ctrl+Z in the editor undoes the whole drag, and the image follows
    n = await renders(page);
    await page.focus("#scene");
    await page.keyboard.press("Control+z");
    if ((await editorText()) !== before) return "Ctrl+Z did not restore the camera text of before the drag";
    await waitDone(page, n);
    const r = await canvasEqualsServer(page);
    if (r !== true) return "after the undo: " + r;
    // and with the focus on the image, Ctrl+Shift+Z redoes it
    n = await renders(page);
    await page.focus("#canvas");
    await page.keyboard.press("Control+Shift+z");
    if ((await editorText()) !== moved) return "Ctrl+Shift+Z on the image did not redo the move";
    await waitDone(page, n);
  });

  const edited = exampleOf("paper").replace('"radius": 0.7', '"radius": 0.75');
  await check("example_over_edit_is_undoable", async () => {
    if (edited === exampleOf("paper")) return "could not edit paper.json";
    await showScene(edited);
    let n = await renders(page);
    await page.selectOption("#example", "whitted");
    await waitDone(page, n);
    if ((await editorText()) !== exampleOf("whitted")) return "the example was not loaded";
    const notice = await page.$eval("#notice", (e) => (e.hidden ? "" : e.textContent.replace(/\s+/g, " ").trim()));
    if (!/Example loaded — Ctrl\+Z to get your scene back/.test(notice)) return `notice "${notice}"`;
    n = await renders(page);
    await page.focus("#scene");
    await page.keyboard.press("Control+z");
    if ((await editorText()) !== edited) return "Ctrl+Z did not bring the edited scene back";
    await waitDone(page, n);
    const menu = await page.$eval("#example", (s) => s.value);
    const hidden = await page.$eval("#notice", (e) => e.hidden);
    if (menu !== "paper" || !hidden) return `after the undo the menu shows ${menu}, notice hidden: ${hidden}`;
    return canvasEqualsServer(page);
  });

  await check("autosave_restores_after_reload", async () => {
    // typed, not set: the way people edit
    await page.focus("#scene");
    await page.keyboard.press("Control+End");
    await page.keyboard.type("\n");
    const text = await editorText();
    if (text !== edited + "\n") return "typing did not reach the editor";
    const saved = () => page.evaluate(() => JSON.parse(localStorage.getItem("rayd.scene") || "null"));
    if (!(await until(async () => ((await saved()) || {}).text === text, 60000))) return "the text was not saved";
    await page.reload();
    await waitDone(page, 0);
    const got = await editorText();
    const menu = await page.$eval("#example", (s) => s.value);
    if (got !== text) return "the reloaded page does not show the edited text";
    return menu === "paper" || `menu shows ${menu}`;
  });

  await check("reset_to_example_is_undoable", async () => {
    const text = await editorText();
    let n = await renders(page);
    await page.click("#reset");
    await waitDone(page, n);
    if ((await editorText()) !== exampleOf("paper")) return "Reset did not load paper.json as it was";
    if (await page.$eval("#notice", (e) => e.hidden)) return "no notice after replacing edited text";
    n = await renders(page);
    await page.click("#notice-undo");
    if ((await editorText()) !== text) return "the notice's Undo did not bring the edited text back";
    await waitDone(page, n);
  });

  // --- Stop: the render in flight ends, on the server too -----------------------------------------
  await check("stop_cancels_progressive_job", async () => {
    await showScene(exampleOf("paper"));
    if (!(await page.$eval("#stop", (b) => b.disabled))) return "Stop enabled with nothing rendering";
    const sc = JSON.parse(exampleOf("cornell"));
    sc.render = { ...sc.render, width: 96, height: 72, samples: 8 };
    await gate(0);
    try {
      await setText(page, JSON.stringify(sc, null, 2));
      const posted = page.waitForResponse((r) => /\/v1\/jobs\?progressive=1$/.test(r.url()), { timeout: 60000 });
      await page.click("#render");
      const job = await (await posted).json();
      if (!(await until(async () => (await gateState()).queued > 0, 60000))) return "the render never reached the server";
      if (await page.$eval("#stop", (b) => b.disabled)) return "Stop disabled while rendering";
      await page.click("#stop");
      const state = await jobEnded(job.id);
      const gone = state === "canceled" || state === "gone";
      if (!gone) return `the job is still ${state}`;
      const page_ = await page.evaluate(() => [document.body.dataset.state, document.getElementById("stop").disabled]);
      return (page_[0] === "stopped" && page_[1]) || `page state ${page_[0]}, Stop disabled: ${page_[1]}`;
    } finally {
      await gate("open");
    }
  });
  // --- Denoise: the passes refine denoised; the raw pass one click away, no render again ------
  await check("denoise_toggle_and_raw_pass", async () => {
    const sc = JSON.parse(exampleOf("cornell"));
    sc.render = { ...sc.render, width: 96, height: 72, samples: 4 };
    const text = JSON.stringify(sc, null, 2);
    await setText(page, text);
    let jobs = 0;
    const count = (r) => {
      if (r.method() === "POST" && /\/v1\/jobs\?/.test(r.url())) jobs++;
    };
    page.on("request", count);
    try {
      let n = await renders(page);
      const posted = page.waitForResponse((r) => /\/v1\/jobs\?progressive=1&denoise=1$/.test(r.url()), { timeout: 60000 });
      await page.click("#denoise"); // a change renders again
      const job = await (await posted).json();
      await waitDone(page, n);
      if (job.denoise !== true) return "the job's 202 does not say denoise: " + JSON.stringify(job);
      if (await page.$eval("#raw", (b) => b.disabled)) return "raw disabled after a denoised render";
      const ref = async (q) => {
        const r = await post("/v1/render" + q, text);
        const f = join(WORK, `ref-${++seq}.png`);
        writeFileSync(f, r.bytes);
        return f;
      };
      const denoised = await ref("?denoise=1"),
        raw = await ref("");
      let r = samePixels(denoised, await canvasPng(page));
      if (r !== true) return "the last pass is not the denoised render: " + r;
      const before = jobs;
      await page.click("#raw");
      await page.waitForFunction(() => document.body.dataset.raw === "1", null, { timeout: 60000 });
      if ((await page.$eval("#raw", (b) => b.getAttribute("aria-pressed"))) !== "true") return "raw not pressed";
      r = samePixels(raw, await canvasPng(page));
      if (r !== true) return "raw shown is not the plain render: " + r;
      await page.keyboard.press("r"); // the key too, back to denoised
      await page.waitForFunction(() => document.body.dataset.raw === "0", null, { timeout: 60000 });
      r = samePixels(denoised, await canvasPng(page));
      if (r !== true) return "back to denoised: " + r;
      if (jobs !== before) return `the toggle made ${jobs - before} new jobs`;
      n = await renders(page);
      await page.click("#denoise"); // off again: raw passes, the raw toggle off
      await waitDone(page, n);
      if (!(await page.$eval("#raw", (b) => b.disabled))) return "raw enabled for a render not denoised";
      return samePixels(raw, await canvasPng(page));
    } finally {
      page.off("request", count);
    }
  });
  // A progressive job that ends failed (here: its stream says so, as it
  // does when --max-render-seconds passes before the first pass) is named
  // as such; it used to be shown as "undefined job_failed".
  await check("failed_progressive_job_named", async () => {
    const sc = JSON.parse(exampleOf("cornell"));
    sc.render = { ...sc.render, width: 32, height: 24, samples: 2, seed: 11 };
    const failed = '{"state":"failed","progress":0.0000,"error":"stopped after 1 s by --max-render-seconds"}';
    await page.route("**/v1/jobs/*/events", (r) =>
      r.fulfill({ status: 200, contentType: "text/event-stream", body: `event: done\ndata: ${failed}\n\n` })
    );
    try {
      await setText(page, JSON.stringify(sc, null, 2));
      await page.click("#render");
      await waitState(page, "error");
    } finally {
      await page.unroute("**/v1/jobs/*/events");
    }
    const title = await page.$eval("#error .error-title", (e) => e.textContent);
    const msg = await page.$eval("#error .error-msg", (e) => e.textContent);
    const retry = await page.$eval("#retry", (e) => !e.hidden);
    return (
      (title === "Render failed (job_failed)" && msg.includes("--max-render-seconds") && retry) ||
      `title "${title}", message "${msg}", retry shown: ${retry}`
    );
  });
  // The job's event stream breaks (a proxy's timeout, the network): the
  // page says so and deletes the job, which would otherwise go on rendering
  // for no one.  The gate holds the job, so it is still there to delete.
  await check("broken_stream_deletes_job", async () => {
    const sc = JSON.parse(exampleOf("cornell"));
    sc.render = { ...sc.render, width: 96, height: 72, samples: 8, seed: 12 };
    await gate(0);
    await page.route("**/v1/jobs/*/events", (r) =>
      r.fulfill({ status: 200, contentType: "text/event-stream", body: "retry: 1000\n\n" })
    );
    try {
      await setText(page, JSON.stringify(sc, null, 2));
      const posted = page.waitForResponse((r) => /\/v1\/jobs\?progressive=1$/.test(r.url()), { timeout: 60000 });
      await page.click("#render");
      const job = await (await posted).json();
      await waitState(page, "error");
      const msg = await page.$eval("#error .error-msg", (e) => e.textContent);
      if (!msg.includes("event stream ended early")) return `message "${msg}"`;
      const state = await jobEnded(job.id);
      const gone = state === "canceled" || state === "gone";
      return gone || `the job is still ${state}`;
    } finally {
      await page.unroute("**/v1/jobs/*/events");
      await gate("open");
    }
  });
  await check("escape_stops_tiles", async () => {
    const slow = JSON.parse(exampleOf("paper"));
    slow.render = { ...slow.render, width: 1280, height: 720, samples: 4, seed: 7 };
    const gone0 = await metric('rayd_canceled_total{reason="client_gone"}');
    await gate(0);
    try {
      await setText(page, JSON.stringify(slow, null, 2));
      await page.click("#render");
      await page.waitForFunction(() => /0\/\d+ tiles/.test(document.getElementById("status").textContent), null, {
        timeout: 60000,
      });
      if (!(await until(async () => (await gateState()).queued > 0, 60000))) return "the render never reached the server";
      await page.focus("#canvas");
      await page.keyboard.press("Escape");
      let gone1 = gone0;
      await until(async () => (gone1 = await metric('rayd_canceled_total{reason="client_gone"}')) > gone0, 60000);
      if (!(gone1 > gone0)) return `rayd_canceled_total{reason="client_gone"} stayed ${gone0}`;
      const st = await page.$eval("#status", (e) => e.textContent);
      return (await page.evaluate(() => document.body.dataset.state)) === "stopped" || `status "${st}"`;
    } finally {
      await gate("open");
    }
  });

  // Stopped with some of its tiles drawn, the image as far as it got is
  // saved by the PNG button, named as partial (the button stayed disabled).
  // The gate lets server tiles through a few at a time until the page has
  // drawn one of its own (each is many of the server's).
  await check("stopped_render_downloads", async () => {
    const slow = JSON.parse(exampleOf("paper"));
    slow.render = { ...slow.render, width: 1280, height: 720, samples: 4, seed: 8 };
    const drawn = () => page.$eval("#status", (e) => /\b[1-9]\d*\/\d+ tiles/.test(e.textContent));
    await gate(0);
    try {
      await setText(page, JSON.stringify(slow, null, 2));
      await page.click("#render");
      for (let k = 0; k < 200 && !(await drawn()); k++) {
        await gate(4);
        await until(async () => (await drawn()) || (await gateState()).tiles === 0, 10000);
      }
      if (!(await drawn())) return "no tile was drawn";
      await page.click("#stop");
      await waitState(page, "stopped");
      if (await page.$eval("#dl-png", (b) => b.disabled)) return "PNG button disabled after a stop with tiles drawn";
      const [dp] = await Promise.all([page.waitForEvent("download"), page.click("#dl-png")]);
      const name = dp.suggestedFilename();
      if (!name.endsWith("-partial.png")) return `download named ${name}`;
      const f = join(WORK, "partial.png");
      await dp.saveAs(f);
      return samePixels(await canvasPng(page), f);
    } finally {
      await gate("open");
    }
  });

  // --- 1:1: one image pixel per device pixel, at any devicePixelRatio --------------------------
  await check("one_to_one_view", async () => {
    await showScene(exampleOf("paper"));
    const size = () =>
      page.$eval("#canvas", (c) => {
        const r = c.getBoundingClientRect();
        return { w: r.width, h: r.height, iw: c.width, ih: c.height, dpr: devicePixelRatio };
      });
    const isOneToOne = (s) => Math.abs(s.w - s.iw / s.dpr) < 0.01 && Math.abs(s.h - s.ih / s.dpr) < 0.01;
    const fitted = await size();
    if (isOneToOne(fitted)) return "fitted already 1:1: the case proves nothing";
    await page.click("#one");
    const s1 = await size();
    if (!isOneToOne(s1)) return `1:1 at ratio ${s1.dpr}: ${s1.w} x ${s1.h} for ${s1.iw} x ${s1.ih}`;
    const cdp = await context.newCDPSession(page);
    try {
      // (headless Chromium tells the page of a new ratio only with a new size)
      await cdp.send("Emulation.setDeviceMetricsOverride", { width: 1400, height: 860, deviceScaleFactor: 2, mobile: false });
      await page.waitForFunction(() => devicePixelRatio === 2, null, { timeout: 60000 });
      const ok2 = await until(async () => isOneToOne(await size()), 60000);
      const s2 = await size();
      if (!ok2) return `1:1 at ratio 2: ${s2.w} x ${s2.h} for ${s2.iw} x ${s2.ih}`;
    } finally {
      // back to the context's own viewport and ratio
      await cdp.send("Emulation.setDeviceMetricsOverride", { width: 1440, height: 860, deviceScaleFactor: 1, mobile: false });
      await cdp.detach();
    }
    await page.waitForFunction(() => devicePixelRatio === 1, null, { timeout: 60000 });
    await page.focus("#canvas");
    await page.keyboard.press("1");
    const back = await size();
    const pressed = await page.$eval("#one", (b) => b.getAttribute("aria-pressed"));
    return (!isOneToOne(back) && pressed === "false") || `key 1 left ${back.w} x ${back.h}, aria-pressed ${pressed}`;
  });

  // --- the header is one row at the screenshot's 1440 px ------------------------------------------
  // Every control of the top bar sits on one line (the Token field used to
  // wrap onto a second row there, pushing the panes down).
  await check("header_one_row_1440", async () => {
    const rows = await page.evaluate(() => {
      const tops = [...document.querySelectorAll(".top > :not(.spacer):not([hidden])")]
        .filter((e) => e.getBoundingClientRect().height > 0)
        .map((e) => { const r = e.getBoundingClientRect(); return Math.round(r.top + r.height / 2); });
      return { spread: Math.max(...tops) - Math.min(...tops), n: tops.length };
    });
    return (rows.n >= 8 && rows.spread <= 4) || `the header's ${rows.n} controls span ${rows.spread} px vertically: more than one row`;
  });

  // --- a narrow, short window: the panes stack and the page scrolls to the image ---------------
  // The image pane keeps its whole height (canvas, progress bar, status
  // line with its buttons) and main scrolls to it; it used to be squeezed
  // into what was left under the editor (2 px at 700 x 400), clipped.
  await check("narrow_window_image_reachable", async () => {
    try {
      for (const [w, h] of [[700, 400], [800, 600], [420, 860]]) {
        await page.setViewportSize({ width: w, height: h });
        await page.waitForFunction(() => getComputedStyle(document.querySelector("main")).gridTemplateColumns.split(" ").length === 1);
        const geometry = () =>
          page.evaluate(() => {
            const r = (s) => document.querySelector(s).getBoundingClientRect();
            const pane = r(".view-pane"), canvas = r("#canvas"), st = r(".statusline");
            const m = document.querySelector("main");
            return { paneTop: pane.top, paneBottom: pane.bottom, canvasTop: canvas.top, canvasH: canvas.height,
                     stBottom: st.bottom, main: m.scrollHeight, mainClient: m.clientHeight };
          });
        const fits = (g) => g.canvasH >= 100 && g.canvasTop >= g.paneTop && g.stBottom <= g.paneBottom + 1;
        // the canvas is sized to its stage after a resize observer fires: wait for it
        await until(async () => fits(await geometry()), 60000);
        const g = await geometry();
        if (!(g.canvasH >= 100)) return `${w} x ${h}: the canvas is ${g.canvasH} px tall`;
        if (g.canvasTop < g.paneTop || g.stBottom > g.paneBottom + 1)
          return `${w} x ${h}: the image pane (${g.paneTop}..${g.paneBottom}) clips the canvas (top ${g.canvasTop}) or the status line (bottom ${g.stBottom})`;
        const lastVisible = await page.evaluate(() => {
          const m = document.querySelector("main");
          m.scrollTop = m.scrollHeight;
          const b = document.querySelector(".statusline").getBoundingClientRect();
          return b.bottom <= innerHeight + 1 && b.top >= 0;
        });
        if (!lastVisible) return `${w} x ${h}: scrolling main does not bring the status line into view (main ${g.main} of ${g.mainClient})`;
      }
      return true;
    } finally {
      await page.setViewportSize({ width: 1440, height: 860 });
    }
  });

  // --- the orbit stops at the ground unless asked ------------------------------------------------
  // Dragging up tilts the eye down (theta grows); from the bottom of the
  // image to the top is more than enough to reach the floor.
  await check("orbit_stays_above_ground", async () => {
    await showScene(exampleOf("whitted")); // a checker plane at y = 0 under look_at [0, 1, 0]
    const camera = async () => JSON.parse(await editorText()).camera.position;
    const box = await canvasBox();
    let n = await renders(page);
    await drag(box.x + box.w / 2, box.y + box.h - 4, 0, -(box.y + box.h - 8), 20);
    await waitDone(page, n);
    const p = await camera();
    if (!(p[1] > 0)) return `the eye went under the ground: ${p}`;
    if (!(p[1] < 0.05)) return `the drag did not bring the eye down to the ground: ${p}`;
    // asked (the box ticked), the same drag goes under
    await page.check("#under");
    try {
      n = await renders(page);
      await drag(box.x + box.w / 2, box.y + box.h - 4, 0, -(box.y + box.h - 8), 20);
      await waitDone(page, n);
    } finally {
      await page.uncheck("#under");
    }
    const q = await camera();
    return q[1] < 0 || `with "under ground" ticked the eye stayed at ${q}`;
  });

  // --- a rayd with --token-file: the Token field authorizes the page's requests -----------------
  if (process.env.TOKEN_URL)
    await check("token_field", async () => {
      const p = await context.newPage();
      const TURL = process.env.TOKEN_URL;
      // rayd asks a token for the page itself too: a proxy in front would add it; so does this route
      await p.route(
        (u) => u.href.startsWith(TURL) && !/^\/(v1\/|metrics)/.test(u.pathname),
        (r) => r.continue({ headers: { ...r.request().headers(), authorization: "Bearer " + process.env.TOKEN } })
      );
      await p.goto(TURL + "/");
      await waitState(p, "error", 30000);
      const msg = await p.$eval("#error", (e) => e.textContent);
      if (!/401/.test(msg) || !/token/i.test(msg)) return `without a token: "${msg}"`;
      await p.fill("#token", process.env.TOKEN);
      await p.dispatchEvent("#token", "change");
      await p.click("#retry");
      await waitDone(p, 0, 30000);
      const status = await p.$eval("#status", (e) => e.textContent);
      await p.close();
      return /rays\/s|from cache/.test(status) || `status "${status}" (no /metrics with the token?)`;
    });

  // every page of the run (renders, errors, orbits, downloads, links,
  // progressive jobs, 1:1) worked under the CSP: not one violation
  await check("no_csp_violations", () => cspViolations.length === 0 || cspViolations.slice(0, 5).join(" | "));

  // --- figures (MEASURE=1): first full image at 1280x720, orbit preview frame rate ----------------
  if (MEASURE) {
    const { examples } = await import(join(OUT_DIR, "server/web/examples.js"));
    // the Cornell box, path-traced: time from the click to the first whole
    // (noisy) frame and to each pass, on a page already open
    const cornell = JSON.parse(examples.find((e) => e.name === "cornell").text);
    for (const [w, h] of [[320, 320], [1280, 720]])
      for (let run = 0; run < 3; run++) {
        cornell.render = { ...cornell.render, width: w, height: h, samples: w === 320 ? 128 : 32, seed: 300 + run };
        const n = await renders(page);
        await setText(page, JSON.stringify(cornell, null, 2));
        await page.click("#render");
        await waitDone(page, n, 600000);
        const s = await page.evaluate(() => window.rayd.stats);
        const each = s.passes.map((q) => `${q.samples}:${(q.ms / 1000).toFixed(3)}`).join(" ");
        console.log(
          `INFO cornell_${w}x${h} run ${run + 1}: quick pass ${s.lastPreviewMs.toFixed(0)} ms, first pass ${s.firstPassMs.toFixed(0)} ms; samples:seconds after the click ${each}`
        );
      }
    const base = JSON.parse(examples.find((e) => e.name === "whitted").text);
    base.render.width = 1280;
    base.render.height = 720;
    const cold = join(WORK, "m.json");
    for (let run = 0; run < 3; run++) {
      base.render.seed = 100 + run; // other bytes, so no cache helps; whitted's image does not depend on it
      writeFileSync(cold, JSON.stringify(base, null, 2));
      // opened as the user's saved scene (a link's would wait for Render)
      await page.evaluate(
        (t) => localStorage.setItem("rayd.scene", JSON.stringify({ text: t, example: "", edited: true })),
        JSON.stringify(base, null, 2)
      );
      const p = await context.newPage();
      const t = Date.now();
      await p.goto(URL + "/");
      await waitDone(p, 0, 120000);
      const s = await p.evaluate(() => window.rayd.stats);
      console.log(
        `INFO first_full_1280x720 run ${run + 1}: quick pass ${s.lastPreviewMs.toFixed(0)} ms, full image ${s.lastFullMs.toFixed(0)} ms after navigation start (wall ${Date.now() - t} ms), ${(s.raysPerSec / 1e6).toFixed(1)} M rays/s`
      );
      base.render.seed = 200 + run; // the same picture in one POST /v1/render, for comparison
      const tq = Date.now();
      const whole = await post("/v1/render", JSON.stringify(base, null, 2));
      console.log(`INFO same_scene_one_post_render run ${run + 1}: ${Date.now() - tq} ms (status ${whole.status})`);
      // the orbit preview: 3 s of dragging, a mouse event every 16 ms
      const box = await p.$eval("#canvas", (c) => c.getBoundingClientRect().toJSON());
      const f0 = await p.evaluate(() => window.rayd.stats.previewFrames);
      const cx = box.x + box.width / 2,
        cy = box.y + box.height / 2;
      await p.mouse.move(cx, cy);
      await p.mouse.down();
      const start = Date.now();
      let k = 0;
      while (Date.now() - start < 3000) {
        k++;
        await p.mouse.move(cx + 150 * Math.sin(k / 20), cy + 40 * Math.sin(k / 33));
        await p.waitForTimeout(16);
      }
      const secs = (Date.now() - start) / 1000;
      const f1 = await p.evaluate(() => window.rayd.stats.previewFrames);
      const ms = await p.evaluate((n) => window.rayd.stats.previewMs.slice(-n), f1 - f0);
      await p.mouse.up();
      ms.sort((a, b) => a - b);
      console.log(
        `INFO orbit_preview_320x180 run ${run + 1}: ${f1 - f0} frames in ${secs.toFixed(1)} s = ${((f1 - f0) / secs).toFixed(1)} fps (frame round trip median ${ms[ms.length >> 1]?.toFixed(0)} ms)`
      );
      await p.close();
    }
    console.log(`INFO page_open_to_first_render_640x480 ${openMs} ms`);
  }
} catch (e) {
  fail("driver", e.stack || e);
} finally {
  await close();
}
process.exit(0);
