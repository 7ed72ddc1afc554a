// json_unit.mjs EXAMPLES.js -- the preview's JSON helpers (server/web/json.js,
// camera.js) in Node, without a browser: pointer -> line, in-place edits,
// the formatter of the examples, orbit and dolly.  Prints PASS/FAIL lines.
import { parse, pointerOffset, lineOf, replaceAt, format, fmtVector, JsonSyntaxError } from "../../server/web/json.js";
import { cameraOf, orbit, dolly } from "../../server/web/camera.js";
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
check("syntax_error_offset", () => {
  try {
    parse('{"a": 1 "b": 2}');
    return "no error";
  } catch (e) {
    return (e instanceof JsonSyntaxError && e.offset === 8) || `offset ${e.offset}`;
  }
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
    if (f.split("\n").some((l) => l.length > 140) && ex.name !== "instances") return `${ex.name}: a line over 140`;
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
check("vector_format", () => fmtVector([1 / 3, -0.00001, 2]) === "[0.3333, 0, 2]" || fmtVector([1 / 3, -0.00001, 2]));
process.exit(0); // the FAIL lines count
