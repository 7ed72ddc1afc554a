// jobs_view_cluster.mjs URL_A URL_B -- the preview's Jobs tab against two
// nodes of one cluster (rayd --redis, both with --test-gate), in Debian's
// Chromium, printing one "PASS name" or "FAIL name: why" line per case.  Run
// by jobs_view_cluster.sh, which starts Redis and the nodes.
//
// A job is submitted from the page served by node A and followed on the
// page of node B: B lists it, follows it on its event stream (tile by tile,
// while the gates let the tiles through), shows it succeeded with its
// thumbnail, and its PNG link gives the bytes node A gives; a job with
// the EXR box offers its EXR on B too.  Nothing is answered by a stand-in.
import { cases } from "./cases.mjs";
import { launch } from "./chromium.mjs";
import { execFileSync } from "node:child_process";
import { mkdtempSync, rmSync, readFileSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

const [A, B] = process.argv.slice(2);
const SCENES = process.env.SCENES || "scenes";
const PNGCMP = process.env.PNGCMP;
const WORK = mkdtempSync(join(tmpdir(), "rayd-cluster-page-"));
const { pass, fail, check, failed } = cases();
const gate = async (url, tiles) => (await fetch(url + "/v1/test/gate?tiles=" + tiles, { method: "POST" })).json();
const job = async (url, id) => (await fetch(`${url}/v1/jobs/${id}`)).json();

// A small whitted scene (128 x 96: 2 x 2 tiles of 64), a job of its own.
function sceneText() {
  const s = JSON.parse(readFileSync(join(SCENES, "whitted.json"), "utf8"));
  s.render.width = 128;
  s.render.height = 96;
  s.render.samples = 1;
  s.render.seed = 4242;
  return JSON.stringify(s, null, 2);
}
// A small path-traced scene (64 x 48, 4 samples): the preview makes it a
// progressive job, which the cluster renders pass by pass (denoised, it
// refuses it, and the page falls back to a plain job).
function pathText(seed) {
  const s = JSON.parse(readFileSync(join(SCENES, "cornell.json"), "utf8"));
  Object.assign(s.render, { width: 64, height: 48, samples: 4, seed });
  return JSON.stringify(s, null, 2);
}
// The canvas of page p against node url's POST /v1/render of text (pngcmp).
async function canvasIsServers(p, url, text) {
  const data = await p.evaluate(() => document.getElementById("canvas").toDataURL("image/png"));
  const res = await fetch(url + "/v1/render", { method: "POST", headers: { "Content-Type": "application/json" }, body: text });
  if (res.status !== 200) return `POST /v1/render answered ${res.status}`;
  const a = join(WORK, "canvas.png"), b = join(WORK, "server.png");
  writeFileSync(a, Buffer.from(data.split(",")[1], "base64"));
  writeFileSync(b, Buffer.from(await res.arrayBuffer()));
  try {
    execFileSync(PNGCMP, [b, a], { stdio: ["ignore", "ignore", "pipe"] });
    return true;
  } catch (e) {
    return (e.stderr && e.stderr.toString().trim()) || `pngcmp exit ${e.status}`;
  }
}
const renders = (p) => p.evaluate(() => Number(document.body.dataset.renders || 0));
const waitDone = (p, n) =>
  p.waitForFunction((k) => document.body.dataset.state === "done" && Number(document.body.dataset.renders || 0) > k, n, {
    timeout: 120000,
  });
const isRefusal = (e) => /^400 POST .*\/v1\/jobs\?.*progressive=1/.test(e);

const rowSel = (id) => `#jobs-list li[data-id="${id}"]`;
const waitRow = (page, id, state) =>
  page.waitForFunction(([sel, s]) => document.querySelector(sel)?.dataset.state === s, [rowSel(id), state], {
    timeout: 60000,
  });

async function open(context, url) {
  const page = await context.newPage();
  const errors = [];
  page.on("console", (m) => m.type() === "error" && !/^Failed to load resource/.test(m.text()) && errors.push(m.text()));
  page.on("response", (r) => r.status() >= 400 && errors.push(`${r.status()} ${r.request().method()} ${r.url()}`));
  page.on("pageerror", (e) => errors.push("pageerror: " + e.message));
  const streamed = new Set();
  page.on("request", (r) => {
    const m = /\/v1\/jobs\/([0-9a-f]{32})\/events$/.exec(r.url());
    if (m) streamed.add(m[1]);
  });
  await page.goto(url + "/", { waitUntil: "load" });
  await page.waitForFunction(() => document.body.dataset.state === "done", null, { timeout: 60000 });
  return { page, errors, streamed };
}

const { context, close } = await launch(fail, { viewport: { width: 1280, height: 800 } });

try {
  let a, b, id;
  await check("pages_open_on_both_nodes", async () => {
    a = await open(context, A);
    b = await open(context, B);
  });
  if (!a || !b) throw new Error("a node's page did not render its example; the other cases were not run");

  await check("submitted_on_a", async () => {
    await gate(A, 0);
    await gate(B, 0);
    await a.page.evaluate((t) => window.rayd.editor.set(t), sceneText());
    await a.page.selectOption("#job-priority", "high");
    await a.page.click("#render-job");
    await a.page.waitForSelector("#jobs-list li[data-id]", { timeout: 30000 });
    id = await a.page.$eval("#jobs-list li[data-id]", (li) => li.dataset.id);
    return /^[0-9a-f]{32}$/.test(id) || `job id "${id}"`;
  });
  if (!id) throw new Error("no job was submitted; the other cases were not run");

  await check("listed_on_b", async () => {
    await b.page.click("#tab-jobs");
    await b.page.click("#jobs-refresh");
    await b.page.waitForSelector(rowSel(id), { timeout: 30000 });
    const state = await b.page.getAttribute(rowSel(id), "data-state");
    const text = await b.page.innerText(rowSel(id));
    if (state !== "queued" && state !== "running") return `state ${state}`;
    return /high/.test(text) || `row "${text}" does not say high`;
  });

  await check("progress_followed_on_b", async () => {
    await b.page.waitForFunction(() => window.rayd.jobs.streams.size === 1, null, { timeout: 30000 });
    if (!b.streamed.has(id)) return "node B's page did not follow the job on its event stream";
    await gate(A, "open"); // A draws the tiles it holds, B still holds its own
    await b.page.waitForFunction(
      (sel) => /^[1-3]\/4 tiles$/.test(document.querySelector(`${sel} .job-ptext`)?.textContent || ""),
      rowSel(id),
      { timeout: 30000 }
    );
    return (await b.page.getAttribute(rowSel(id), "data-state")) === "running" || "not running after a tile";
  });

  let png = null;
  await check("done_on_b_with_thumbnail", async () => {
    await gate(B, "open");
    await waitRow(b.page, id, "succeeded");
    await b.page.waitForFunction((sel) => document.querySelector(`${sel} .job-ptext`).textContent === "4/4 tiles", rowSel(id));
    await b.page.waitForFunction((sel) => document.querySelector(sel).dataset.thumb === "loaded", rowSel(id));
    const w = await b.page.$eval(`${rowSel(id)} .job-thumb img`, (img) => img.naturalWidth);
    if (w !== 128) return `thumbnail naturalWidth ${w}, not 128`;
    png = Buffer.from(await (await fetch(`${A}/v1/jobs/${id}/image.png`)).arrayBuffer());
    const j = await job(B, id);
    return j.state === "succeeded" || `node B says ${j.state}`;
  });

  await check("download_on_b_is_a_image", async () => {
    const href = await b.page.$eval(`${rowSel(id)} a.job-dl`, (a) => a.href);
    if (href !== `${B}/v1/jobs/${id}/image.png`) return `href ${href}`;
    const [dl] = await Promise.all([b.page.waitForEvent("download"), b.page.click(`${rowSel(id)} a.job-dl`)]);
    const got = readFileSync(await dl.path());
    return (png && png.length > 100 && got.equals(png)) || `downloaded ${got.length} bytes, node A's PNG ${png && png.length}`;
  });

  await check("a_shows_it_done_too", async () => {
    await waitRow(a.page, id, "succeeded");
  });

  // A path-traced scene on node B's page: a progressive job of the
  // cluster, drawn pass by pass; its last pass is the server's pixels.
  await check("path_traced_progressive_on_b", async () => {
    await b.page.click("#tab-editor");
    for (const seed of [1, 2]) {
      const n = await renders(b.page), text = pathText(seed);
      await b.page.evaluate((t) => window.rayd.editor.set(t), text);
      await b.page.focus("#scene");
      await b.page.keyboard.press("Control+Enter");
      try {
        await waitDone(b.page, n);
      } catch (e) {
        const st = await b.page.evaluate(() => [document.body.dataset.state, document.getElementById("status").textContent]);
        return `seed ${seed}: not done (state ${st[0]}, status "${st[1]}"); requests failed: ${b.errors.join(" | ")}`;
      }
      const same = await canvasIsServers(b.page, B, text);
      if (same !== true) return `seed ${seed}: ${same}`;
    }
    const asks = b.errors.filter(isRefusal).length;
    return asks === 0 || `${asks} refused progressive asks, not 0`;
  });

  // The Jobs view posts it as a progressive job, which succeeds with its
  // passes; with the denoise box, the cluster refuses that (its passes
  // are not denoised) once, and the page posts it as a plain job.
  const newRow = (known) =>
    b.page.waitForFunction((ids) => {
      const li = [...document.querySelectorAll("#jobs-list li[data-id]")].find((l) => !ids.includes(l.dataset.id));
      return li && li.dataset.state === "succeeded" ? li.dataset.id : false;
    }, known, { timeout: 60000 });
  const listed = () => b.page.$$eval("#jobs-list li[data-id]", (ls) => ls.map((l) => l.dataset.id));
  await check("path_traced_job_progressive_on_b", async () => {
    await b.page.click("#tab-jobs");
    const known = await listed();
    await b.page.click("#render-job");
    const pid = await (await newRow(known)).jsonValue();
    const j = await job(A, pid);
    const asks = b.errors.filter(isRefusal).length;
    if (asks !== 0) return `${asks} refused progressive asks, not 0`;
    return (j.passes && j.passes.done === 3 && j.passes.samples === 4) || `passes on A: ${JSON.stringify(j.passes)}`;
  });
  await check("path_traced_denoised_job_plain_on_b", async () => {
    await b.page.check("#denoise");
    const known = await listed();
    await b.page.click("#render-job");
    const did = await (await newRow(known)).jsonValue();
    await b.page.uncheck("#denoise");
    const j = await job(A, did);
    const asks = b.errors.filter(isRefusal).length; /* the canvas's too: the box renders again */
    if (asks < 1) return "no refused progressive ask";
    return (!j.passes && j.denoise === true) || `the job on A: ${JSON.stringify(j).slice(0, 300)}`;
  });
  b.errors.splice(0, b.errors.length, ...b.errors.filter((e) => !isRefusal(e)));

  // A job that keeps an EXR, posted from A's page with the EXR box: B's
  // page offers the EXR, and its bytes are the ones A gives.
  await check("exr_job_on_a_downloads_on_b", async () => {
    await a.page.click("#tab-jobs");
    const before = new Set(await a.page.$$eval("#jobs-list li[data-id]", (ls) => ls.map((l) => l.dataset.id)));
    await a.page.check("#job-exr");
    await a.page.evaluate((t) => window.rayd.editor.set(t), sceneText());
    await a.page.click("#render-job");
    await a.page.waitForFunction((known) => [...document.querySelectorAll("#jobs-list li[data-id]")].some((l) => !known.includes(l.dataset.id)), [...before], { timeout: 30000 });
    const xid = (await a.page.$$eval("#jobs-list li[data-id]", (ls) => ls.map((l) => l.dataset.id))).find((i) => !before.has(i));
    await a.page.uncheck("#job-exr");
    await b.page.click("#tab-jobs");
    await b.page.click("#jobs-refresh");
    await waitRow(b.page, xid, "succeeded");
    await b.page.waitForFunction((sel) => document.querySelectorAll(`${sel} a.job-dl`).length === 2, rowSel(xid));
    const links = await b.page.$$eval(`${rowSel(xid)} a.job-dl`, (as) => as.map((x) => [x.textContent, x.href]));
    const want = [["PNG", `${B}/v1/jobs/${xid}/image.png`], ["EXR", `${B}/v1/jobs/${xid}/image.exr`]];
    if (JSON.stringify(links) !== JSON.stringify(want)) return `links ${JSON.stringify(links)}`;
    const fromB = Buffer.from(await (await fetch(`${B}/v1/jobs/${xid}/image.exr`)).arrayBuffer());
    const fromA = Buffer.from(await (await fetch(`${A}/v1/jobs/${xid}/image.exr`)).arrayBuffer());
    const magic = fromB.subarray(0, 4).equals(Buffer.from([0x76, 0x2f, 0x31, 0x01]));
    return (magic && fromB.equals(fromA)) || `EXR from B: ${fromB.length} bytes (magic ${magic}), from A: ${fromA.length}`;
  });

  await check("no_page_errors", async () => {
    const all = [...a.errors, ...b.errors];
    return all.length === 0 || all.join(" | ");
  });
} catch (e) {
  fail("driver", e.stack || e);
} finally {
  await close();
  rmSync(WORK, { recursive: true, force: true });
}
process.exit(0);
