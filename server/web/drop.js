// drop.js -- the user's model put into the editor's scene, framed and lit.
//
// model.js reads the files; here they become part of the scene:
//
// - Objects.  A model dropped (or opened) before, any object whose source
//   is embedded ("text" or "base64"), makes way for the new one, so a
//   second drop replaces the first rather than piling up at the same place.
//   On an example left as it was, the example's objects make way too, all
//   but its ground planes: the user came to see the model, not the example's
//   spheres around it.  In a scene of the user's own, the other objects stay.
// - Ground.  With a ground plane left (ground.js's kind: a top-level plane
//   facing up, with no transform), the model is set on it: a transform lifts
//   or lowers it so its lowest point touches the plane (a model centred on
//   the origin would otherwise be cut in half by the floor).
// - Light.  A scene with no lights and no environment would render black
//   (a glTF file's own lights count): a key light and a soft constant
//   environment are added, the environment invisible to the camera, so the
//   background stays the scene's.  An HDR or EXR dropped becomes the
//   environment, replacing the scene's.
// - Camera.  It looks at the centre of the model's box from the direction
//   it looked before (from the three-quarter view when it had none the
//   controls can move, or looked straight down), at the distance where the
//   box's circumscribed sphere fits the smaller field of view with a 10%
//   margin: the rule of "frame": "all" (docs/scene-format.md), done here so
//   the orbit and dolly still work.  A camera the renderer placed ("frame")
//   becomes an explicit one.
//
// The scene is then printed again (json.js format) as one undoable step.

import { cameraOf } from "./camera.js";
import { folded } from "./fold.js";

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const len = (a) => Math.sqrt(dot(a, a));
const round = (v) => v.map((x) => Math.round(x * 1e5) / 1e5 || 0);
const isObj = (v) => v && typeof v === "object" && !Array.isArray(v);

export const DEFAULT_LIGHT = { type: "directional", direction: [-1, -2, -1.5], color: [1, 1, 1], intensity: 0.9 };
export const DEFAULT_FILL = { color: [0.35, 0.35, 0.38], visible: false };

const embedded = (o) => isObj(o) && isObj(o.source) && (o.source.text !== undefined || o.source.base64 !== undefined);
const isGround = (o) => isObj(o) && o.type === "plane" && o.transform === undefined;

function union(boxes) {
  const got = boxes.filter(Boolean);
  if (!got.length) return null;
  return {
    min: [0, 1, 2].map((k) => Math.min(...got.map((b) => b.min[k]))),
    max: [0, 1, 2].map((k) => Math.max(...got.map((b) => b.max[k]))),
  };
}

// The half angle (radians) of the smaller field of view of the scene's camera.
function halfFov(cam, size) {
  const [w, h] = size;
  const t = (deg) => Math.tan((deg * Math.PI) / 360);
  let tx, ty;
  if (typeof cam.fov_x === "number" && typeof cam.fov_y === "number") [tx, ty] = [t(cam.fov_x), t(cam.fov_y)];
  else if (typeof cam.fov_y === "number") [ty, tx] = [t(cam.fov_y), (t(cam.fov_y) * w) / h];
  else {
    tx = t(typeof cam.fov_x === "number" ? cam.fov_x : 60);
    ty = (tx * h) / w;
  }
  return Math.atan(Math.min(tx, ty));
}

// The height of the highest plane facing up (within 30 degrees) over the
// origin, or null.
function groundLevel(objects) {
  let best = null;
  for (const o of objects) {
    if (!isGround(o)) continue;
    const n = Array.isArray(o.normal) ? o.normal : [0, 1, 0];
    const p = Array.isArray(o.point) ? o.point : [0, 0, 0];
    if (!(len(n) > 0) || n[1] / len(n) < Math.cos(Math.PI / 6)) continue;
    const h = dot(n, p) / n[1];
    if (isFinite(h) && (best === null || h > best)) best = h;
  }
  return best;
}

// The scene's camera (old) moved to look at box, from where it looked.
export function frameCamera(old, box, size) {
  const cam = isObj(old) ? { ...old } : {};
  const now = cameraOf({ camera: cam });
  let dir = now ? sub(now.position, now.lookAt) : null;
  dir = dir && len(dir) > 0 ? mul(dir, 1 / len(dir)) : null;
  if (!dir || Math.abs(dir[1]) > 0.97) {
    const az = Math.PI / 4,
      el = Math.PI / 6;
    dir = [Math.sin(az) * Math.cos(el), Math.sin(el), Math.cos(az) * Math.cos(el)];
  }
  for (const k of ["frame", "view", "azimuth", "elevation"]) delete cam[k];
  const centre = mul(add(box.min, box.max), 0.5);
  const r = Math.max(len(sub(box.max, box.min)) / 2, 1e-6);
  const d = (r / Math.sin(halfFov(cam, size))) * 1.1;
  cam.position = round(add(centre, mul(dir, d)));
  cam.look_at = round(centre);
  const up = now && now.up;
  cam.up = up && len(up) > 0 && Math.abs(dot(up, dir)) < 0.99 * len(up) ? up : [0, 1, 0];
  if (cam.projection === "orthographic") cam.view_width = Math.round(2.2 * r * Math.max(1, size[0] / size[1]) * 1e5) / 1e5;
  if (typeof cam.aperture === "number" && cam.aperture > 0) cam.focus_distance = Math.round(d * 1e5) / 1e5;
  return cam;
}

// The scene with the files of got (model.js readFiles) in it.  example: the
// scene is an example left as it was; size: its [width, height].  Returns
// {scene, framed, lit}: framed when the camera moved, lit when a default
// light was added.
export function withModels(scene, got, { example, size }) {
  const s = { ...scene };
  let framed = false,
    lit = false;
  const render = isObj(s.render) ? { ...s.render } : {};
  if (got.env) render.environment = got.env.value;
  if (got.models.length) {
    let objects = Array.isArray(s.objects) ? s.objects.filter((o) => !embedded(o)) : [];
    if (example) objects = objects.filter(isGround);
    const box = union(got.models.map((m) => m.bounds));
    const ground = box ? groundLevel(objects) : null;
    const lift = ground !== null ? ground - box.min[1] : 0;
    for (const m of got.models) {
      const o = { ...m.object };
      if (lift) o.transform = { translate: round([0, lift, 0]) };
      objects.push(o);
    }
    s.objects = objects;
    // a box no camera can frame (garbage read as floats, or coordinates past
    // the scene format's 1e9) leaves the camera alone: the server's error on
    // the file is the one to show
    const sane = box && [...box.min, ...box.max].every((x) => Math.abs(x) < 1e8);
    if (sane) {
      const placed = { min: add(box.min, [0, lift, 0]), max: add(box.max, [0, lift, 0]) };
      s.camera = frameCamera(s.camera, placed, size);
      framed = true;
    }
    const lights = Array.isArray(s.lights) && s.lights.length > 0;
    if (!lights && !render.environment && !got.models.some((m) => m.lights)) {
      s.lights = [DEFAULT_LIGHT];
      render.environment = DEFAULT_FILL;
      lit = true;
    }
  }
  if (Object.keys(render).length || s.render !== undefined) s.render = render;
  return { scene: s, framed, lit };
}

// got (model.js readFiles) with its long strings folded (fold.js): the
// editor shows tokens in their place.
export function foldFiles(got) {
  for (const m of got.models) {
    const src = { ...m.object.source };
    for (const k of ["text", "base64"]) if (typeof src[k] === "string") src[k] = folded(src[k], m.name);
    m.object = { ...m.object, source: src };
  }
  if (got.env) got.env.value = { ...got.env.value, base64: folded(got.env.value.base64, got.env.name) };
  return got;
}

// Bytes of text as UTF-8: what the server counts against --max-body.
export function utf8Length(text) {
  let n = text.length;
  for (let i = 0; i < text.length; i++) {
    const c = text.charCodeAt(i);
    if (c < 0x80) continue;
    if (c < 0x800) n += 1;
    else if (c >= 0xd800 && c < 0xdc00) {
      n += 2; // a pair: 4 bytes for 2 units
      i++;
    } else n += 2;
  }
  return n;
}

const mb = (n) => (n >= 1e6 ? `${(n / 1e6).toFixed(1)} MB` : `${Math.ceil(n / 1e3)} kB`);

// The message for a scene of bytes over the server's limit.
export function tooLargeMessage(names, bytes, limit) {
  const env = /\.(hdr|exr)$/i.test(names[0]);
  const suggest = Math.ceil((bytes * 1.1) / 1048576) * 1048576;
  const ref = env ? `"environment": {"file": "${names[0]}"}` : `"source": {"file": "${names[0]}"}`;
  return (
    `With ${names.join(", ")} embedded, the scene is ${mb(bytes)} (${bytes} bytes), over this server's ` +
    `limit of ${mb(limit)} (--max-body ${limit}). To render it:\n` +
    `- start rayd with a larger --max-body (its operator's setting), e.g. rayd --max-body ${suggest};\n` +
    `- or put the file under the server's --asset-dir and name it in the scene: ${ref};\n` +
    "- or send it smaller: binary PLY or .glb instead of OBJ text (base64 adds a third; text OBJ is the largest)."
  );
}

// Drag and drop on the whole page, and the Open button's file input: each
// calls open(FileList).  body.dropping is set while files are dragged over.
export function wireDrop(button, input, open) {
  button.addEventListener("click", () => input.click());
  input.addEventListener("change", () => {
    if (input.files && input.files.length) open(Array.from(input.files));
    input.value = ""; // the same file chosen again opens again
  });
  const hasFiles = (e) => e.dataTransfer && Array.from(e.dataTransfer.types || []).includes("Files");
  let depth = 0;
  document.addEventListener("dragenter", (e) => {
    if (!hasFiles(e)) return;
    depth++;
    document.body.classList.add("dropping");
  });
  document.addEventListener("dragleave", () => {
    if (depth > 0 && --depth === 0) document.body.classList.remove("dropping");
  });
  document.addEventListener("dragover", (e) => {
    if (!hasFiles(e)) return;
    e.preventDefault();
    e.dataTransfer.dropEffect = "copy";
  });
  document.addEventListener("drop", (e) => {
    depth = 0;
    document.body.classList.remove("dropping");
    if (!e.dataTransfer || !e.dataTransfer.files || !e.dataTransfer.files.length) return;
    e.preventDefault();
    open(Array.from(e.dataTransfer.files));
  });
}
