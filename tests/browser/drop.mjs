// drop.mjs URL -- the preview's Open button and drag and drop, driven in
// Debian's Chromium against the rayd at URL (started by drop.sh with
// --max-body 2500000).  One "PASS name" or "FAIL name: why" line per case.
//
// Files go in the way a user gives them: setInputFiles on the Open button's
// <input type=file>, and a drop event carrying a DataTransfer of Files (the
// one Chromium builds when files are dragged from the desktop).  The cases
// check what the user would see: the editor's scene holds the file embedded
// (byte for byte), the render succeeds (every image the page fetched
// answered 200 image/png), the model is in the picture (the middle of the
// canvas differs from the same scene rendered without the model) and fits
// it (the edges do not), and the refusals say what to do.
import { cases } from "./cases.mjs";
import { launch } from "./chromium.mjs";
import { readFileSync } from "node:fs";
import { join, basename } from "node:path";

const URL = process.argv[2];
const MODELS = process.env.MODELS || "/usr/share/assimp/models";
const SCENES = process.env.SCENES || "scenes";
const { pass, fail, check, failed } = cases("page_opens");
const assert = (ok, why) => {
  if (!ok) throw new Error(why);
};

const OBJ = join(MODELS, "OBJ/spider.obj");
const PLY = join(MODELS, "PLY/cube_binary.ply");
const PLY_POINTS = join(MODELS, "PLY/points.ply"); // a point cloud: refused by the server
const PLY_BIG = join(MODELS, "PLY/pond.0.ply"); // 2.2 MB binary: over 2500000 once in base64
const GLB = join(MODELS, "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb");
const GLTF_DIR = join(MODELS, "glTF2/BoxTextured-glTF");
const GLTF = [join(GLTF_DIR, "BoxTextured.gltf"), join(GLTF_DIR, "BoxTextured0.bin"), join(GLTF_DIR, "CesiumLogoFlat.png")];
const STL = join(MODELS, "STL/Spider_binary.stl");
const HDR = join(SCENES, "sky.hdr");
const EXR = join(process.env.RAYD_ROOT || ".", "tests/fuzz/corpus/envmap/tiny-8x4.exr");
const b64 = (path) => readFileSync(path).toString("base64");

// A scene of the user's own: no lights, a dark background, and one object
// of theirs far out of the way (it must stay).
const USER_SCENE = JSON.stringify(
  {
    camera: { position: [0, 0, 5], look_at: [0, 0, 0], fov_x: 50 },
    render: { width: 160, height: 120, background: [0.05, 0.05, 0.08] },
    objects: [{ type: "sphere", name: "mine", center: [500, 500, 500], radius: 1 }],
  },
  null,
  2
);

// The scene as the page sends it (the editor shows long strings folded).
const scene = (page) => page.evaluate(() => JSON.parse(window.rayd.sceneText()));
const embeddedOf = (s) => (s.objects || []).filter((o) => o.source && (o.source.text !== undefined || o.source.base64 !== undefined));

// Runs act (which opens or drops files) and waits for its outcome: a new
// finished render ("done") or an error shown.  The images fetched meanwhile
// are returned with their statuses.
async function outcome(page, act) {
  await page.evaluate(() => {
    document.getElementById("error").hidden = true;
    document.body.dataset.state = "test-idle";
  });
  const before = await page.evaluate(() => Number(document.body.dataset.renders || 0));
  const images = [];
  const onResponse = (r) => {
    const u = r.url();
    if (/\/v1\/(render|scenes)/.test(u)) images.push({ url: u, status: r.status(), type: r.headers()["content-type"] || "" });
  };
  page.on("response", onResponse);
  try {
    await act();
    await page.waitForFunction(
      (b) => {
        const s = document.body.dataset.state;
        return (s === "done" && Number(document.body.dataset.renders || 0) > b) || s === "error";
      },
      before,
      { timeout: 120000 }
    );
  } finally {
    page.off("response", onResponse);
  }
  const state = await page.evaluate(() => document.body.dataset.state);
  const error = await page.evaluate(() => ({
    title: document.querySelector("#error .error-title").textContent,
    msg: document.querySelector("#error .error-msg").textContent,
  }));
  return { state, error, images };
}

function renderedOk(o) {
  assert(o.state === "done", `state ${o.state}: ${o.error.title}: ${o.error.msg}`);
  const pngs = o.images.filter((i) => i.type.startsWith("image/png"));
  assert(pngs.length > 0, "no image/png answer seen");
  const bad = o.images.filter((i) => i.status !== 200 && i.status !== 201);
  assert(!bad.length, "answers not 200: " + JSON.stringify(bad));
}

// The canvas against the same scene rendered without the embedded models:
// the share of pixels that differ in the middle ninth, and on the edges
// (the outer 3% of each side).
async function modelInView(page) {
  const s = await scene(page);
  const ref = { ...s, objects: s.objects.filter((o) => !embeddedOf({ objects: [o] }).length) };
  return page.evaluate(async (refText) => {
    const c = document.getElementById("canvas");
    const w = c.width,
      h = c.height;
    const a = c.getContext("2d").getImageData(0, 0, w, h).data;
    const res = await fetch("v1/render", { method: "POST", headers: { "Content-Type": "application/json" }, body: refText });
    if (!res.ok) return { error: `reference render: ${res.status} ${await res.text()}` };
    const bmp = await createImageBitmap(await res.blob(), { colorSpaceConversion: "none", premultiplyAlpha: "none" });
    const oc = new OffscreenCanvas(w, h);
    const o = oc.getContext("2d");
    o.drawImage(bmp, 0, 0);
    const b = o.getImageData(0, 0, w, h).data;
    const differs = (x, y) => {
      const k = 4 * (y * w + x);
      return Math.abs(a[k] - b[k]) + Math.abs(a[k + 1] - b[k + 1]) + Math.abs(a[k + 2] - b[k + 2]) > 24;
    };
    let mid = 0,
      midN = 0,
      edge = 0,
      edgeN = 0;
    const ex = Math.max(1, Math.round(w * 0.03)),
      ey = Math.max(1, Math.round(h * 0.03));
    for (let y = 0; y < h; y++)
      for (let x = 0; x < w; x++) {
        if (x >= w / 3 && x < (2 * w) / 3 && y >= h / 3 && y < (2 * h) / 3) {
          midN++;
          if (differs(x, y)) mid++;
        } else if (x < ex || x >= w - ex || y < ey || y >= h - ey) {
          edgeN++;
          if (differs(x, y)) edge++;
        }
      }
    return { mid: mid / midN, edge: edge / edgeN, w, h };
  }, JSON.stringify(ref));
}

async function inView(page, { edges = true } = {}) {
  const v = await modelInView(page);
  assert(!v.error, v.error);
  assert(v.mid > 0.3, `only ${(100 * v.mid).toFixed(1)}% of the middle differs from the scene without the model`);
  if (edges) assert(v.edge < 0.05, `${(100 * v.edge).toFixed(1)}% of the edges differ: the model overflows the frame`);
  return v;
}

// A drop of files on the page, as Chromium delivers one from the desktop.
async function dropFiles(page, paths, target = "#stage") {
  const files = paths.map((p) => ({ name: basename(p), data: b64(p) }));
  await page.evaluate(
    ({ files, target }) => {
      const dt = new DataTransfer();
      for (const f of files) {
        const bytes = Uint8Array.from(atob(f.data), (c) => c.charCodeAt(0));
        dt.items.add(new File([bytes], f.name));
      }
      const el = document.querySelector(target);
      for (const type of ["dragenter", "dragover", "drop"])
        el.dispatchEvent(new DragEvent(type, { dataTransfer: dt, bubbles: true, cancelable: true }));
    },
    { files, target }
  );
}
const openFiles = (page, paths) => page.setInputFiles("#open-file", paths);
const setUserScene = (page) => page.evaluate((t) => window.rayd.editor.set(t), USER_SCENE);

const { context, close } = await launch(fail, { viewport: { width: 1440, height: 860 } });
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
  page.on("pageerror", (e) => consoleErrors.push("pageerror: " + e.message));
  await page.goto(URL + "/", { waitUntil: "load" });
  let opened = false;
  await check("page_opens", async () => {
    await page.waitForFunction(() => document.body.dataset.state === "done", null, { timeout: 120000 });
    assert(await page.locator("#open").isVisible(), "no visible Open button");
    opened = true;
  });
  if (!opened) throw new Error("the page did not render its example; the other cases were not run");

  // The OBJ through the Open button, on the example the page opened with:
  // the example's spheres make way, its ground stays and the model is set
  // on it (spider.obj's lowest point is at y = -42.2).
  await check("open_obj_on_example", async () => {
    const text = readFileSync(OBJ, "utf8");
    const o = await outcome(page, () => openFiles(page, [OBJ]));
    renderedOk(o);
    const s = await scene(page);
    const m = embeddedOf(s);
    assert(m.length === 1 && m[0].type === "mesh" && m[0].source.format === "obj", "no obj mesh: " + JSON.stringify(m.map((x) => x.type)));
    assert(m[0].source.text === text, "the OBJ text is not the file's");
    // 105 kB: folded in the editor, whose text stays small
    const shown = await page.evaluate(() => window.rayd.editor.value);
    assert(shown.length < 10000 && /characters of spider\.obj #\d+/.test(shown), `the editor holds ${shown.length} characters`);
    assert(s.objects.length === 2 && s.objects[0].type === "plane", "the example's objects are not [plane, model]: " + s.objects.map((x) => x.type));
    const lift = m[0].transform && m[0].transform.translate;
    assert(lift && Math.abs(lift[1] - 42.233826) < 1e-3, "not set on the ground: " + JSON.stringify(m[0].transform));
    // the camera looks at the middle of the box, lifted
    const ys = [...text.matchAll(/^v\s+(\S+)\s+(\S+)\s+(\S+)/gm)];
    const lo = [0, 1, 2].map((k) => Math.min(...ys.map((v) => Number(v[k + 1]))));
    const hi = [0, 1, 2].map((k) => Math.max(...ys.map((v) => Number(v[k + 1]))));
    const c = [0, 1, 2].map((k) => (lo[k] + hi[k]) / 2 + (k === 1 ? lift[1] : 0));
    const la = s.camera.look_at;
    assert(la.every((x, k) => Math.abs(x - c[k]) < 1e-2), `look_at ${la} is not the box centre ${c}`);
    assert(s.lights.length === 2, "the example's lights were not kept");
    await inView(page, { edges: false }); // the ground's shadows may reach the edges
    const note = await page.locator("#notice-text").textContent();
    assert(/Opened spider\.obj/.test(note), "no notice: " + note);
  });

  await check("undo_gives_the_scene_back", async () => {
    const before = await page.evaluate(() => window.rayd.editor.value);
    await page.evaluate(() => window.rayd.editor.undo());
    const after = await page.evaluate(() => window.rayd.editor.value);
    assert(after !== before && !after.includes('"source"'), "undo did not restore the example");
    await page.evaluate(() => window.rayd.editor.redo());
  });

  // A binary PLY dropped on a scene of the user's own with no lights.
  await check("drop_binary_ply", async () => {
    await setUserScene(page);
    const o = await outcome(page, () => dropFiles(page, [PLY]));
    renderedOk(o);
    const s = await scene(page);
    const m = embeddedOf(s);
    assert(m.length === 1 && m[0].type === "mesh" && m[0].source.format === "ply", "no ply mesh");
    assert(m[0].source.base64 === b64(PLY), "the PLY's base64 is not the file's");
    assert(s.objects.some((x) => x.name === "mine"), "the user's own object was dropped");
    assert(Array.isArray(s.lights) && s.lights.length === 1, "no default light added to a scene without lights");
    const la = s.camera.look_at;
    assert(la.every((x) => Math.abs(x - 0.5) < 1e-6), "look_at is not the cube's centre: " + la);
    await inView(page);
  });

  // A .glb with its texture, dropped: it replaces the PLY.
  await check("drop_glb_textured", async () => {
    const o = await outcome(page, () => dropFiles(page, [GLB]));
    renderedOk(o);
    const s = await scene(page);
    const m = embeddedOf(s);
    assert(m.length === 1, `${m.length} embedded models: the PLY was not replaced`);
    assert(m[0].type === "gltf" && m[0].source.format === "glb" && m[0].source.base64 === b64(GLB), "no glb gltf object of the file's bytes");
    await inView(page);
    // the texture: the box's faces show more than a few colours
    const colours = await page.evaluate(() => {
      const c = document.getElementById("canvas");
      const d = c.getContext("2d").getImageData(c.width / 3, c.height / 3, c.width / 3, c.height / 3).data;
      const set = new Set();
      for (let k = 0; k < d.length; k += 4) set.add((d[k] >> 4) * 256 + (d[k + 1] >> 4) * 16 + (d[k + 2] >> 4));
      return set.size;
    });
    assert(colours >= 8, `only ${colours} colours in the middle: no texture`);
  });

  // A .gltf with its .bin and texture chosen together.
  await check("open_gltf_with_bin_and_texture", async () => {
    const o = await outcome(page, () => openFiles(page, GLTF));
    renderedOk(o);
    const s = await scene(page);
    const m = embeddedOf(s);
    assert(m.length === 1 && m[0].type === "gltf" && m[0].source.format === "gltf", "no gltf object");
    const g = JSON.parse(m[0].source.text);
    const bin = "data:application/octet-stream;base64," + b64(GLTF[1]);
    assert(g.buffers[0].uri === bin, "the .bin is not embedded as a data: URI");
    assert(g.images[0].uri === "data:image/png;base64," + b64(GLTF[2]), "the texture is not embedded as a data: URI");
    await inView(page);
  });

  await check("drop_gltf_without_bin_says_so", async () => {
    const before = await page.evaluate(() => window.rayd.editor.value);
    const o = await outcome(page, () => dropFiles(page, [GLTF[0]]));
    assert(o.state === "error", "no error shown, state " + o.state);
    assert(/BoxTextured0\.bin/.test(o.error.msg) && /CesiumLogoFlat\.png/.test(o.error.msg), "the missing files are not named: " + o.error.msg);
    assert(/together/.test(o.error.msg), "does not say to choose them together: " + o.error.msg);
    assert((await page.evaluate(() => window.rayd.editor.value)) === before, "the editor changed");
  });

  // An HDR: the scene's environment, the model kept.
  await check("open_hdr_environment", async () => {
    const corner = () =>
      page.evaluate(() => Array.from(document.getElementById("canvas").getContext("2d").getImageData(1, 1, 1, 1).data).slice(0, 3));
    await outcome(page, () => page.evaluate(() => window.rayd.render()));
    const was = await corner();
    const o = await outcome(page, () => openFiles(page, [HDR]));
    renderedOk(o);
    const s = await scene(page);
    const env = s.render.environment;
    assert(env && env.format === "hdr" && env.base64 === b64(HDR), "render.environment is not the HDR's base64");
    assert(embeddedOf(s).length === 1, "the model was not kept");
    const now = await corner();
    assert(now.some((x, k) => Math.abs(x - was[k]) > 8), `the background did not change: ${was} -> ${now}`);
  });

  // Several files dropped at once: a .gltf with its .bin and texture, and
  // an EXR environment (a README.txt beside them is ignored, and said so).
  await check("drop_gltf_set_and_exr", async () => {
    const o = await outcome(page, () => dropFiles(page, [...GLTF, EXR, join(SCENES, "../README.md")]));
    renderedOk(o);
    const s = await scene(page);
    const m = embeddedOf(s);
    assert(m.length === 1 && m[0].type === "gltf" && m[0].source.format === "gltf", "no gltf object");
    assert(JSON.parse(m[0].source.text).buffers[0].uri.startsWith("data:application/octet-stream;base64,"), "the .bin is not embedded");
    const env = s.render.environment;
    assert(env && env.format === "exr" && env.base64 === b64(EXR), "render.environment is not the EXR's base64");
    const note = await page.locator("#notice-text").textContent();
    assert(/ignored README\.md/.test(note), "the ignored file is not named: " + note);
  });

  await check("over_limit_says_what_to_do", async () => {
    const before = await page.evaluate(() => window.rayd.editor.value);
    const o = await outcome(page, () => openFiles(page, [PLY_BIG]));
    assert(o.state === "error", "no error shown, state " + o.state);
    assert(/pond\.0\.ply/.test(o.error.title), "the title does not name the file: " + o.error.title);
    for (const w of ["--max-body 2500000", "--asset-dir", ".glb", "binary PLY"])
      assert(o.error.msg.includes(w), `the message lacks "${w}": ${o.error.msg}`);
    assert(!o.images.length, "the scene was sent anyway: " + JSON.stringify(o.images));
    assert((await page.evaluate(() => window.rayd.editor.value)) === before, "the editor changed");
  });

  await check("wrong_type_named", async () => {
    const before = await page.evaluate(() => window.rayd.editor.value);
    const o = await outcome(page, () => dropFiles(page, [STL]));
    assert(o.state === "error", "no error shown, state " + o.state);
    assert(o.error.msg.includes('"Spider_binary.stl"') && /not a file type/.test(o.error.msg), "the file is not named: " + o.error.msg);
    assert(/\.obj/.test(o.error.msg) && /\.hdr/.test(o.error.msg), "the types it takes are not named: " + o.error.msg);
    assert((await page.evaluate(() => window.rayd.editor.value)) === before, "the editor changed");
  });

  await check("malformed_editor_scene_kept", async () => {
    const broken = '{"objects": [';
    await page.evaluate((t) => window.rayd.editor.set(t), broken);
    const o = await outcome(page, () => openFiles(page, [PLY]));
    assert(o.state === "error" && /not a valid JSON object/.test(o.error.msg), "no message: " + o.error.msg);
    assert((await page.evaluate(() => window.rayd.editor.value)) === broken, "the editor's text was replaced");
    await page.evaluate(() => window.rayd.editor.undo());
  });

  // A file the server cannot read: its error, with the JSON Pointer and the
  // line in the editor, as for any scene error.
  await check("bad_file_gets_the_server_error", async () => {
    const o = await outcome(page, () => openFiles(page, [PLY_POINTS]));
    assert(o.state === "error", "no error shown, state " + o.state);
    assert(/^\/objects\/\d+\/source\/text/.test(o.error.msg), "no JSON Pointer: " + o.error.msg);
    assert(/point cloud/.test(o.error.msg), "not the server's message: " + o.error.msg);
    const line = await page.evaluate(() => Number(document.getElementById("editor").dataset.errorLine || 0));
    assert(line > 0, "no line marked in the editor");
  });

  await check("no_csp_violations", () => (cspViolations.length ? cspViolations.join(" | ") : true));
  await check("no_page_errors", () => (consoleErrors.length ? consoleErrors.join(" | ") : true));
} catch (e) {
  fail("drop_run", e.message);
} finally {
  await close();
}
process.exit(failed() ? 1 : 0);
