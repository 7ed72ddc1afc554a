// json_unit.mjs EXAMPLES.js -- the preview's JSON helpers (server/web/json.js,
// camera.js, ground.js, history.js, fold.js, model.js, drop.js) in Node,
// without a browser: pointer -> line, in-place edits, the formatter of the
// examples, orbit and dolly and their stop at the ground, the undo history,
// long strings folded out of the editor and back, a model's bounding box,
// and a model put in a scene.  Prints PASS/FAIL lines.
import { parse, pointerOffset, lineOf, offsetOfLine, replaceAt, format, fmtVector, JsonSyntaxError } from "../../server/web/json.js";
import { cameraOf, orbit, dolly } from "../../server/web/camera.js";
import { groundHeight, eyeFloor } from "../../server/web/ground.js";
import { TextHistory, changedRange } from "../../server/web/history.js";
import { fold, unfold, folded, FOLD_MIN } from "../../server/web/fold.js";
import { objBounds, plyBounds, gltfBounds } from "../../server/web/model.js";
import { withModels, utf8Length } from "../../server/web/drop.js";
import { isDeepStrictEqual } from "node:util";

const { examples } = await import(process.argv[2]);
let ok = true;
function check(name, fn) {
  try {
    const r = fn();
    if (r === true) console.log(`PASS ${name}`);
    else {
      ok = false;
      console.log(`FAIL ${name}: ${r}`);
    }
  } catch (e) {
    ok = false;
    console.log(`FAIL ${name}: ${e.message}`);
  }
}

const text = `{
  "camera": {"position": [0, 1, 6]},
  "a/b": {"~x": [1,
    2, 3]},
  "objects": [
    {"type": "sphere"},
    {"type": "sphere",
     "radius": -1},
    {"radius": 1, "radius": 2}
  ]
}`;
const root = parse(text);
const at = (p) => lineOf(text, pointerOffset(root, p));

check("json_parse_matches_JSON_parse", () => isDeepStrictEqual(root.value, JSON.parse(text)) || "values differ");
check("pointer_to_line", () => {
  const want = { "": 1, "/camera": 2, "/camera/position": 2, "/objects/1/radius": 8, "/objects/1": 7,
    "/a~1b/~0x/2": 4, "/a~1b": 3, "/objects/2/radius": 9, "/objects/1/missing": 7, "/objects/9": 5 };
  for (const [p, l] of Object.entries(want)) if (at(p) !== l) return `${p} at line ${at(p)}, want ${l}`;
  return true;
});
check("pointer_with_a_cut_key", () => {
  // rayd's pointer for the bad key below: the name cut to 64 bytes, with "..."
  const name = "a/b" + "m".repeat(77);
  const t = `{"materials": {\n  "x": {},\n  ${JSON.stringify(name)}: {\n    "colr": 1}}}`;
  const ptr = "/materials/a~1b" + "m".repeat(60) + ".../colr";
  const line = lineOf(t, pointerOffset(parse(t), ptr));
  return line === 4 || `line ${line}, want 4`;
});
check("syntax_error_offset", () => {
  try {
    parse('{"a": 1 "b": 2}');
    return "no error";
  } catch (e) {
    return (e instanceof JsonSyntaxError && e.offset === 8) || `offset ${e.offset}`;
  }
});
// rayd counts a column per character; an emoji is two UTF-16 units of the
// text, so adding the column to the line's offset put the caret before the
// error on a line with an emoji in a name.
check("column_counts_characters", () => {
  // rayd's answer for this text: line 2, column 43, at "angle"
  const t = '{"materials": {"\u{1F525}": {}},\n "lights": [{"name": "\u{1F525}\u{1F525}", "type": "spot" "angle": 5}]}';
  const got = [offsetOfLine(t, 2, 43), offsetOfLine("ab\ncd", 1, 9), offsetOfLine("ab\ncd", 3, 1)];
  const want = [t.indexOf('"angle"'), 2, 5];
  return isDeepStrictEqual(got, want) || `offsets ${got}, want ${want}`;
});
check("replace_keeps_the_rest", () => {
  const t2 = replaceAt(text, root, ["camera", "position"], "[1, 2, 3]");
  const want = text.replace("[0, 1, 6]", "[1, 2, 3]");
  if (t2 !== want) return "text differs";
  const t3 = replaceAt("{}", parse("{}"), ["camera", "position"], "[1, 2, 3]");
  return isDeepStrictEqual(JSON.parse(t3), { camera: { position: [1, 2, 3] } }) || t3;
});
check("format_examples_round_trip", () => {
  for (const ex of examples) {
    const v = JSON.parse(ex.text);
    const f = format(v);
    if (!isDeepStrictEqual(JSON.parse(f), v)) return `${ex.name} changes when formatted`;
    // a string (an embedded image's base64) cannot be broken; anything else can
    const oneString = (l) => /^\s*("[^"]*": )?"[^"]*",?$/.test(l);
    const long = f.split("\n").some((l) => l.length > 140 && !oneString(l));
    if (long && ex.name !== "instances") return `${ex.name}: a line over 140`;
  }
  return true;
});
check("orbit_keeps_distance", () => {
  const cam = cameraOf({ camera: { position: [0, 1.5, 6], look_at: [0, 1, 0] } });
  const p = orbit(cam, 0.7, -0.3);
  const d = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
  if (Math.abs(d(p, cam.lookAt) - d(cam.position, cam.lookAt)) > 1e-9) return "distance changed";
  if (d(p, cam.position) < 0.1) return "did not move";
  const top = orbit(cam, 0, 10); // dragging down far past the pole: stops short of it
  const up = (top[1] - 1) / d(top, cam.lookAt);
  if (!(up < 1 && up > 0.99)) return `pole clamp: cos ${up}`;
  const q = dolly(cam, 0.5);
  return Math.abs(d(q, cam.lookAt) - d(cam.position, cam.lookAt) / 2) < 1e-9 || "dolly";
});
check("framed_camera_does_not_orbit", () => {
  // "frame": "all" refuses a position beside it, so the preview must not write one
  return cameraOf({ camera: { frame: "all", view: "front" } }) === null || "cameraOf gave a camera";
});
check("gltf_camera_does_not_orbit", () => {
  // a gltf object's "camera" sets the scene's camera and /camera/position is
  // refused beside it: orbiting the gltf example used to write one, and the
  // next render failed with 422
  const gltf = JSON.parse(examples.find((e) => e.name === "gltf").text);
  const own = { objects: [{ type: "gltf", source: { text: "{}" } }], camera: { position: [0, 1, 5] } };
  if (cameraOf(gltf) !== null) return "cameraOf gave a camera for the gltf example";
  return cameraOf(own) !== null || "a gltf object without a camera stopped the orbit";
});
check("ground_of_scenes", () => {
  const cam = cameraOf({ camera: { position: [0, 2, 7], look_at: [0, 1, 0] } });
  const cases = [
    [{ objects: [{ type: "plane", point: [0, -0.5, 0], normal: [0, 1, 0] }] }, -0.5],
    [{ objects: [{ type: "plane" }] }, 0], // the defaults: y = 0, normal +y
    [{ objects: [{ type: "plane", point: [0, -2, 0], normal: [0, -1, 0] }, { type: "plane", point: [0, -1, 0] }] }, -1],
    [{ objects: [{ type: "plane", point: [0, 3, 0] }] }, 0], // above look_at: a ceiling, not the ground
    [{ objects: [{ type: "plane", point: [0, -1, 0], normal: [1, 0, 0] }] }, 0], // a wall
    [{ objects: [{ type: "plane", point: [0, -1, 0], transform: { translate: [0, 5, 0] } }] }, 0],
    [{ objects: [] }, 0],
  ];
  for (const [scene, want] of cases) {
    const got = groundHeight(scene, cam);
    if (Math.abs(got - want) > 1e-12) return `${JSON.stringify(scene)}: ground ${got}, want ${want}`;
  }
  const low = cameraOf({ camera: { position: [0, -2, 7], look_at: [0, -3, 0] } });
  if (groundHeight({}, low) !== -3) return `look_at below 0: ground ${groundHeight({}, low)}`;
  const zup = cameraOf({ camera: { position: [7, 0, 2], look_at: [0, 0, 1], up: [0, 0, 1] } });
  const g = groundHeight({ objects: [{ type: "plane", point: [0, 0, -1], normal: [0, 0, 1] }] }, zup);
  return g === -1 || `z up: ground ${g}`;
});
check("orbit_stops_at_the_ground", () => {
  const scene = { camera: { position: [0, 2, 7], look_at: [0, 1, 0] }, objects: [{ type: "plane" }] };
  const cam = cameraOf(scene);
  const floor = eyeFloor(scene, cam);
  const d = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
  const under = orbit(cam, 0, -3); // a drag up: the eye goes down and round
  if (!(under[1] < 0)) return `without a floor the eye should go under: ${under}`;
  const p = orbit(cam, 0, -3, floor);
  if (!(p[1] >= floor - 1e-12 && p[1] < floor + 1e-6)) return `with the floor ${floor}: eye at ${p}`;
  if (Math.abs(d(p, cam.lookAt) - d(cam.position, cam.lookAt)) > 1e-9) return "distance changed";
  // an eye already under the ground is never lifted, only kept from going lower
  const below = { ...cam, position: [0, -1, 7] };
  const q = orbit(below, 0.3, -1, floor);
  if (Math.abs(q[1] - -1) > 1e-9) return `an eye under the ground moved to ${q}`;
  // the dolly away from look_at stops at the floor too, and never pushes
  const low = { ...cam, position: [0, 0.5, 4] };
  const far = dolly(low, 10, floor);
  if (!(far[1] >= floor - 1e-12 && far[1] < floor + 1e-6)) return `dolly out: eye at ${far}`;
  const near = dolly(low, 0.5, floor);
  return Math.abs(d(near, low.lookAt) - d(low.position, low.lookAt) / 2) < 1e-9 || "dolly in changed";
});
check("history_undo_redo_groups", () => {
  const h = new TextHistory("a");
  h.record("ab", { kind: "typing", group: "t1" });
  h.record("abc", { kind: "typing", group: "t1" }); // the same word: one step
  h.record("abc!", { kind: "camera", group: "m1", label: "paper" });
  h.record("abc!!", { kind: "camera", group: "m1", label: "paper" }); // the same drag: one step
  if (h.states.length !== 3) return `${h.states.length} states, want 3`;
  let u = h.undo();
  if (u.text !== "abc" || u.kind !== "camera" || u.label !== "") return `undo: ${JSON.stringify(u)}`;
  // after an undo, the same group makes a new step, never rewrites the one undone to
  h.record("abcd", { kind: "typing", group: "t1" });
  if (h.states.length !== 3 || h.canRedo()) return "a change after an undo should drop the redo states";
  u = h.undo();
  if (u.text !== "abc") return `second undo: ${u.text}`;
  const r = h.redo();
  if (r.text !== "abcd" || r.kind !== "typing") return `redo: ${JSON.stringify(r)}`;
  if (h.record("abcd")) return "recording the same text is a step";
  const small = new TextHistory("0", 3);
  for (let k = 1; k <= 5; k++) small.record(String(k));
  if (small.states.length !== 3 || small.undo().text !== "4" || small.undo().text !== "3" || small.undo() !== null)
    return "the limit keeps the newest states";
  return true;
});
check("changed_range", () => {
  const r = changedRange('{"p": [0, 1, 6]}', '{"p": [0.5, 1, 6]}');
  return (r.start === 8 && r.end === 10) || JSON.stringify(r);
});
check("vector_format", () => fmtVector([1 / 3, -0.00001, 2]) === "[0.3333, 0, 2]" || fmtVector([1 / 3, -0.00001, 2]));
// fold.js: long strings out of the editor's text and back, escapes kept
check("fold_roundtrip", () => {
  const long = "a\"b\\c\n".repeat(FOLD_MIN / 4);
  const scene = { objects: [{ type: "mesh", source: { format: "obj", text: long } }], s: "short \" one" };
  const text = JSON.stringify(scene, null, 2);
  const f = fold(text);
  if (f.length > 1000) return `folded text still ${f.length} characters`;
  if (!isDeepStrictEqual(Object.keys(parse(f).value), ["objects", "s"])) return "the folded text is not the same tree";
  if (unfold(f) !== text) return "unfold(fold(text)) is not text";
  const v = folded(long, 'x"y.obj');
  if (v.includes('"') || JSON.parse(unfold(JSON.stringify({ v }))).v !== long) return "folded() does not unfold to the string";
  if (unfold('{"a": "<5 characters of z #999, kept by the page and sent in their place>"}').indexOf("#999") < 0)
    return "an unknown token must be left as it is";
  return fold('{"a": "short"}') === '{"a": "short"}' || "a short text changed";
});
// model.js: the boxes the camera frames
check("model_bounds", () => {
  const obj = objBounds("# c\nv 1 2 3\nvt 9 9\n  v -1 -2 -3 1\nvn 5 5 5\nf 1 2 2\n");
  if (!isDeepStrictEqual(obj, { min: [-1, -2, -3], max: [1, 2, 3] })) return "obj: " + JSON.stringify(obj);
  const head = "ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list uchar int vertex_indices\n" +
    "element vertex 2\nproperty uchar r\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  const body = new DataView(new ArrayBuffer(1 + 12 + 2 * 13));
  body.setUint8(0, 3);
  [[5, -1, 2, 0.5], [6, 4, -2, 1]].forEach(([r, x, y, z], i) => {
    const o = 13 + 13 * i;
    body.setUint8(o, r);
    body.setFloat32(o + 1, x, true);
    body.setFloat32(o + 5, y, true);
    body.setFloat32(o + 9, z, true);
  });
  const bytes = new Uint8Array([...new TextEncoder().encode(head), ...new Uint8Array(body.buffer)]);
  const ply = plyBounds(bytes);
  if (!isDeepStrictEqual(ply, { min: [-1, -2, 0.5], max: [4, 2, 1] })) return "ply (a face element first): " + JSON.stringify(ply);
  const g = {
    scene: 0, scenes: [{ nodes: [0] }],
    nodes: [{ translation: [10, 0, 0], scale: [2, 2, 2], children: [1] }, { mesh: 0 }],
    meshes: [{ primitives: [{ attributes: { POSITION: 0 } }] }],
    accessors: [{ min: [-1, -1, -1], max: [1, 1, 1] }],
  };
  const gb = gltfBounds(g, () => null);
  return isDeepStrictEqual(gb, { min: [8, -2, -2], max: [12, 2, 2] }) || "gltf: " + JSON.stringify(gb);
});
// drop.js: the model framed, set on the ground, lit
check("with_models", () => {
  const got = {
    models: [{ name: "m.obj", object: { type: "mesh", name: "m.obj", source: { format: "obj", text: "x" } }, bounds: { min: [-1, -1, -1], max: [1, 1, 1] }, lights: false }],
    env: null,
  };
  const scene = {
    camera: { position: [0, 0, 10], look_at: [0, 0, 0], fov_y: 40 },
    objects: [{ type: "plane", point: [0, 0.5, 0] }, { type: "sphere", name: "mine" }, { type: "mesh", source: { base64: "old" } }],
  };
  const { scene: s, framed, lit } = withModels(scene, got, { example: false, size: [100, 100] });
  if (!framed || !lit) return "not framed or not lit";
  if (s.objects.length !== 3 || s.objects[1].name !== "mine" || s.objects[2].name !== "m.obj") return "objects: " + JSON.stringify(s.objects);
  if (!isDeepStrictEqual(s.objects[2].transform, { translate: [0, 1.5, 0] })) return "not set on the ground: " + JSON.stringify(s.objects[2].transform);
  const d = (Math.sqrt(3) / Math.sin((20 * Math.PI) / 180)) * 1.1;
  if (!isDeepStrictEqual(s.camera.look_at, [0, 1.5, 0]) || Math.abs(s.camera.position[2] - d) > 1e-4) return "camera: " + JSON.stringify(s.camera);
  const ex = withModels(scene, got, { example: true, size: [100, 100] }).scene;
  if (ex.objects.length !== 2 || ex.objects[0].type !== "plane") return "an example keeps only its ground: " + JSON.stringify(ex.objects);
  const framed2 = withModels({ camera: { frame: "all", view: "top" } }, got, { example: false, size: [100, 100] }).scene.camera;
  if (framed2.frame !== undefined || framed2.view !== undefined || !framed2.position) return "a frame camera: " + JSON.stringify(framed2);
  return utf8Length("aé€😀") === 1 + 2 + 3 + 4 || "utf8Length";
});
process.exit(0); // the FAIL lines count
