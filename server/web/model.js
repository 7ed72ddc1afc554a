// model.js -- the user's own files, read in the page: models and environments.
//
// The preview's Open button and a drop on the page hand over File objects.
// The server reads no file the page could name (without --asset-dir it
// refuses "file" sources), so each file is embedded in the scene the way
// docs/scene-format.md says a source may be: an OBJ as "text", a PLY as
// "text" when it is ASCII and "base64" when binary, a .glb as "base64", a
// .gltf as its JSON "text" with every external buffer and image (chosen or
// dropped with it) turned into a base64 data: URI, an HDR or EXR as an
// environment's "base64".  glTF files become "gltf" objects, so their own
// materials and textures are drawn; OBJ and PLY become meshes.
//
// The camera is framed on the model in the page (drop.js), so it needs the
// model's bounding box: read here from the vertex positions of an OBJ or a
// PLY, and for glTF from each drawn primitive's POSITION min/max (which the
// format requires; the data when they are missing) placed by its node's
// matrix.  This reading is only for the box: whether the file is valid is the
// server's to say, with its JSON Pointer, when the scene is rendered.  A box
// that cannot be found (no vertex read) leaves the camera as it was.

const ENV_FORMATS = { hdr: "hdr", exr: "exr" };
const MODEL_FORMATS = { obj: "obj", ply: "ply", gltf: "gltf", glb: "glb" };
const COMPANIONS = new Set(["bin", "png", "jpg", "jpeg"]); // a .gltf's buffers and images

export const extOf = (name) => {
  const m = /\.([^./\\]+)$/.exec(name);
  return m ? m[1].toLowerCase() : "";
};

export function b64(bytes) {
  let s = "";
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

function unb64(s) {
  const b = atob(s);
  const out = new Uint8Array(b.length);
  for (let i = 0; i < b.length; i++) out[i] = b.charCodeAt(i);
  return out;
}

const utf8 = (bytes) => {
  try {
    return new TextDecoder("utf-8", { fatal: true }).decode(bytes);
  } catch (_) {
    return null;
  }
};

// ---- bounding boxes ---------------------------------------------------------------
class Box {
  constructor() {
    this.min = [Infinity, Infinity, Infinity];
    this.max = [-Infinity, -Infinity, -Infinity];
  }
  add(x, y, z) {
    if (!isFinite(x) || !isFinite(y) || !isFinite(z)) return;
    const p = [x, y, z];
    for (let k = 0; k < 3; k++) {
      if (p[k] < this.min[k]) this.min[k] = p[k];
      if (p[k] > this.max[k]) this.max[k] = p[k];
    }
  }
  get empty() {
    return !(this.min[0] <= this.max[0]);
  }
  result() {
    return this.empty ? null : { min: this.min, max: this.max };
  }
}

export function objBounds(text) {
  const box = new Box();
  const re = /^[ \t]*v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)/gm;
  let m;
  while ((m = re.exec(text))) box.add(Number(m[1]), Number(m[2]), Number(m[3]));
  return box.result();
}

const PLY_TYPES = {
  char: 1, int8: 1, uchar: 1, uint8: 1, short: 2, int16: 2, ushort: 2, uint16: 2,
  int: 4, int32: 4, uint: 4, uint32: 4, float: 4, float32: 4, double: 8, float64: 8,
};
function plyRead(dv, off, type, le) {
  switch (type) {
    case "char": case "int8": return dv.getInt8(off);
    case "uchar": case "uint8": return dv.getUint8(off);
    case "short": case "int16": return dv.getInt16(off, le);
    case "ushort": case "uint16": return dv.getUint16(off, le);
    case "int": case "int32": return dv.getInt32(off, le);
    case "uint": case "uint32": return dv.getUint32(off, le);
    case "float": case "float32": return dv.getFloat32(off, le);
    default: return dv.getFloat64(off, le);
  }
}

// The PLY header: {format, elements: [{name, count, props: [{name, type, list}]}], body}
export function plyHeader(bytes) {
  const head = new TextDecoder("latin1").decode(bytes.subarray(0, Math.min(bytes.length, 65536)));
  const end = /end_header\r?\n/.exec(head);
  if (!head.startsWith("ply") || !end) return null;
  const h = { format: "", elements: [], body: end.index + end[0].length };
  for (const line of head.slice(0, end.index).split(/\r?\n/)) {
    const w = line.trim().split(/\s+/);
    if (w[0] === "format") h.format = w[1];
    else if (w[0] === "element") h.elements.push({ name: w[1], count: Number(w[2]), props: [] });
    else if (w[0] === "property" && h.elements.length) {
      const el = h.elements[h.elements.length - 1];
      if (w[1] === "list") el.props.push({ name: w[4], type: w[3], list: w[2] });
      else el.props.push({ name: w[2], type: w[1] });
    }
  }
  return h;
}

export function plyBounds(bytes) {
  const h = plyHeader(bytes);
  if (!h) return null;
  const box = new Box();
  if (h.format === "ascii") {
    const lines = new TextDecoder("latin1").decode(bytes.subarray(h.body)).split("\n");
    let line = 0;
    for (const el of h.elements) {
      if (el.name !== "vertex") {
        line += el.count;
        continue;
      }
      const at = ["x", "y", "z"].map((n) => el.props.findIndex((p) => p.name === n));
      if (at.some((k) => k < 0)) return null;
      for (let i = 0; i < el.count && line < lines.length; i++, line++) {
        const w = lines[line].trim().split(/\s+/);
        box.add(Number(w[at[0]]), Number(w[at[1]]), Number(w[at[2]]));
      }
      break;
    }
    return box.result();
  }
  const le = h.format === "binary_little_endian";
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  let off = h.body;
  try {
    for (const el of h.elements) {
      const isVertex = el.name === "vertex";
      for (let i = 0; i < el.count; i++) {
        const xyz = [NaN, NaN, NaN];
        for (const p of el.props) {
          if (p.list) {
            const n = plyRead(dv, off, p.list, le);
            off += PLY_TYPES[p.list] + n * PLY_TYPES[p.type];
            continue;
          }
          const k = "xyz".indexOf(p.name);
          if (isVertex && k >= 0 && p.name.length === 1) xyz[k] = plyRead(dv, off, p.type, le);
          off += PLY_TYPES[p.type] || 4;
        }
        if (isVertex) box.add(xyz[0], xyz[1], xyz[2]);
      }
      if (isVertex) break;
    }
  } catch (_) {
    /* cut short: the box of what was read; the server names the fault */
  }
  return box.result();
}

// ---- glTF ----------------------------------------------------------------------------
const I4 = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
function mmul(a, b) {
  // column-major 4x4, as glTF
  const o = new Array(16).fill(0);
  for (let c = 0; c < 4; c++)
    for (let r = 0; r < 4; r++) for (let k = 0; k < 4; k++) o[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
  return o;
}
function nodeMatrix(n) {
  if (Array.isArray(n.matrix) && n.matrix.length === 16) return n.matrix;
  const [x, y, z, w] = Array.isArray(n.rotation) ? n.rotation : [0, 0, 0, 1];
  const [sx, sy, sz] = Array.isArray(n.scale) ? n.scale : [1, 1, 1];
  const [tx, ty, tz] = Array.isArray(n.translation) ? n.translation : [0, 0, 0];
  return [
    (1 - 2 * (y * y + z * z)) * sx, 2 * (x * y + z * w) * sx, 2 * (x * z - y * w) * sx, 0,
    2 * (x * y - z * w) * sy, (1 - 2 * (x * x + z * z)) * sy, 2 * (y * z + x * w) * sy, 0,
    2 * (x * z + y * w) * sz, 2 * (y * z - x * w) * sz, (1 - 2 * (x * x + y * y)) * sz, 0,
    tx, ty, tz, 1,
  ];
}
const place = (m, p) => [0, 1, 2].map((r) => m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);

// The positions' own box of an accessor: its min/max, or its float data.
function accessorBox(g, a, buffer) {
  if (Array.isArray(a.min) && Array.isArray(a.max) && a.min.length >= 3 && a.max.length >= 3)
    return { min: a.min, max: a.max };
  const view = g.bufferViews && g.bufferViews[a.bufferView];
  const bytes = view && buffer(view.buffer);
  if (!bytes || a.componentType !== 5126) return null;
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const stride = view.byteStride || 12;
  const base = (view.byteOffset || 0) + (a.byteOffset || 0);
  const box = new Box();
  for (let i = 0; i < a.count && base + i * stride + 12 <= bytes.length; i++) {
    const o = base + i * stride;
    box.add(dv.getFloat32(o, true), dv.getFloat32(o + 4, true), dv.getFloat32(o + 8, true));
  }
  return box.result();
}

// g: the glTF JSON; buffer(i): buffer i's bytes or null.
export function gltfBounds(g, buffer) {
  const box = new Box();
  const nodes = Array.isArray(g.nodes) ? g.nodes : [];
  let roots;
  const scenes = Array.isArray(g.scenes) ? g.scenes : [];
  const sc = scenes[Number.isInteger(g.scene) ? g.scene : 0];
  if (sc && Array.isArray(sc.nodes)) roots = sc.nodes;
  else {
    const child = new Set(nodes.flatMap((n) => (Array.isArray(n.children) ? n.children : [])));
    roots = nodes.map((_, i) => i).filter((i) => !child.has(i));
  }
  const seen = new Set();
  const walk = (i, parent, depth) => {
    const n = nodes[i];
    if (!n || seen.has(i) || depth > 128) return;
    seen.add(i);
    const m = mmul(parent, nodeMatrix(n));
    const mesh = g.meshes && g.meshes[n.mesh];
    for (const p of (mesh && mesh.primitives) || []) {
      const mode = p.mode === undefined ? 4 : p.mode;
      if (mode < 4 || !p.attributes) continue;
      const a = g.accessors && g.accessors[p.attributes.POSITION];
      const b = a && accessorBox(g, a, buffer);
      if (!b) continue;
      for (let c = 0; c < 8; c++)
        box.add(...place(m, [c & 1 ? b.max[0] : b.min[0], c & 2 ? b.max[1] : b.min[1], c & 4 ? b.max[2] : b.min[2]]));
    }
    for (const c of Array.isArray(n.children) ? n.children : []) walk(c, m, depth + 1);
  };
  for (const r of roots) walk(r, I4, 0);
  return box.result();
}

// A .glb's JSON and BIN chunk, or null.
export function glbChunks(bytes) {
  if (bytes.length < 20) return null;
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (dv.getUint32(0, true) !== 0x46546c67) return null; // "glTF"
  let json = null,
    bin = null;
  for (let off = 12; off + 8 <= bytes.length; ) {
    const len = dv.getUint32(off, true);
    const type = dv.getUint32(off + 4, true);
    const data = bytes.subarray(off + 8, off + 8 + len);
    if (type === 0x4e4f534a && !json) json = data; // "JSON"
    else if (type === 0x004e4942 && !bin) bin = data; // "BIN\0"
    off += 8 + len + ((4 - (len % 4)) % 4);
  }
  return json ? { json, bin } : null;
}

const hasLights = (g) => {
  const l = g && g.extensions && g.extensions.KHR_lights_punctual;
  return !!(l && Array.isArray(l.lights) && l.lights.length);
};

// The bytes of a data: URI, or null.
function dataUri(uri) {
  const m = /^data:[^,]*;base64,(.*)$/s.exec(uri);
  try {
    return m ? unb64(m[1]) : null;
  } catch (_) {
    return null;
  }
}

// ---- a set of files -------------------------------------------------------------------
export class ModelError extends Error {}

const MIME = { png: "image/png", jpg: "image/jpeg", jpeg: "image/jpeg" };

// A .gltf with its buffers and images embedded as data: URIs.  byName maps a
// file's name to its File; a uri is found by its last path segment.
async function embedGltf(file, text, byName, used) {
  let g;
  try {
    g = JSON.parse(text);
  } catch (e) {
    // the server's reader names the line and column: let it
    return { source: { format: "gltf", text }, bounds: null, lights: false };
  }
  const missing = [];
  const bytesOf = [];
  const embed = async (item, kind) => {
    if (!item || typeof item.uri !== "string" || item.uri.startsWith("data:")) return null;
    let name = item.uri;
    try {
      name = decodeURIComponent(item.uri);
    } catch (_) {
      /* keep the uri as it is */
    }
    name = name.split(/[/\\]/).pop();
    const f = byName.get(name);
    if (!f) {
      missing.push(`${name} (${kind})`);
      return null;
    }
    used.add(f);
    const bytes = new Uint8Array(await f.arrayBuffer());
    const mime = item.mimeType || MIME[extOf(name)] || "application/octet-stream";
    item.uri = `data:${mime};base64,${b64(bytes)}`;
    return bytes;
  };
  for (const [i, b] of (Array.isArray(g.buffers) ? g.buffers : []).entries()) {
    const got = await embed(b, "a buffer");
    bytesOf[i] = got || (b && typeof b.uri === "string" ? dataUri(b.uri) : null);
  }
  for (const im of Array.isArray(g.images) ? g.images : []) await embed(im, "an image");
  if (missing.length)
    throw new ModelError(
      `${file.name} refers to ${missing.join(", ")}, which was not chosen with it. ` +
        "Choose (or drop) the .gltf together with its .bin and texture files, or use the model's .glb."
    );
  return {
    source: { format: "gltf", text: JSON.stringify(g) },
    bounds: gltfBounds(g, (i) => bytesOf[i] || null),
    lights: hasLights(g),
  };
}

// One model file: {name, object, bounds, lights}.
async function readModelFile(file, byName, used) {
  const format = MODEL_FORMATS[extOf(file.name)];
  const bytes = new Uint8Array(await file.arrayBuffer());
  let r;
  if (format === "obj") {
    const text = utf8(bytes);
    // not UTF-8 (a UTF-16 export): as bytes, for the server to name the encoding
    r =
      text === null
        ? { source: { format, base64: b64(bytes) }, bounds: null }
        : { source: { format, text }, bounds: objBounds(text) };
  } else if (format === "ply") {
    const h = plyHeader(bytes);
    const text = h && h.format === "ascii" ? utf8(bytes) : null;
    r = { source: text === null ? { format, base64: b64(bytes) } : { format, text }, bounds: plyBounds(bytes) };
  } else if (format === "glb") {
    const c = glbChunks(bytes);
    let g = null;
    try {
      g = c && JSON.parse(new TextDecoder().decode(c.json));
    } catch (_) {
      /* the server says what is wrong */
    }
    r = {
      source: { format, base64: b64(bytes) },
      bounds: g ? gltfBounds(g, (i) => (i === 0 && c.bin ? c.bin : null)) : null,
      lights: hasLights(g),
    };
  } else {
    const text = utf8(bytes);
    r = text === null ? { source: { format, base64: b64(bytes) }, bounds: null } : await embedGltf(file, text, byName, used);
  }
  const gltf = format === "gltf" || format === "glb";
  return {
    name: file.name,
    object: { type: gltf ? "gltf" : "mesh", name: file.name, source: r.source },
    bounds: r.bounds,
    lights: !!r.lights,
  };
}

// What a list of Files holds: {models, env, ignored}.  models: see
// readModelFile; env: a render.environment object (the last HDR or EXR);
// ignored: the names of files that are none of these.  Throws ModelError
// when nothing can be opened, or a .gltf misses a file it names.
export async function readFiles(files) {
  files = Array.from(files);
  const byName = new Map(files.map((f) => [f.name, f]));
  const used = new Set();
  const models = [];
  let env = null;
  for (const f of files) {
    const ext = extOf(f.name);
    if (MODEL_FORMATS[ext]) {
      models.push(await readModelFile(f, byName, used));
      used.add(f);
    } else if (ENV_FORMATS[ext]) {
      env = { name: f.name, value: { base64: b64(new Uint8Array(await f.arrayBuffer())), format: ENV_FORMATS[ext] } };
      used.add(f);
    }
  }
  const ignored = files.filter((f) => !used.has(f)).map((f) => f.name);
  if (!models.length && !env) {
    const lone = ignored.filter((n) => COMPANIONS.has(extOf(n)));
    throw new ModelError(
      `Cannot open ${ignored.map((n) => `"${n}"`).join(", ") || "nothing"}: ` +
        (lone.length === ignored.length && ignored.length
          ? "a .bin, .png or .jpg is opened only with the .gltf that names it (choose them together). "
          : "not a file type the preview reads. ") +
        "It opens models (.obj, .ply, .glb, or a .gltf with its .bin and textures) " +
        "and environment maps (.hdr, .exr)."
    );
  }
  return { models, env, ignored };
}

export const ACCEPT = ".obj,.ply,.gltf,.glb,.bin,.png,.jpg,.jpeg,.hdr,.exr";
