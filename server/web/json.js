// json.js -- a small JSON parser that remembers where every value is.
//
// The server names a bad value by its JSON Pointer (/objects/1/radius); the
// editor needs the line of that value.  parse() builds a tree of nodes with
// their offsets in the text (and the offsets of object keys), pointerOffset()
// walks a pointer down that tree, lineOf() turns an offset into a line.  The
// same tree lets the camera controls replace one value in the text without
// reformatting the rest (replaceAt).  format() pretty-prints a scene the way
// the hand-written examples look: short arrays and objects on one line.

export class JsonSyntaxError extends Error {
  constructor(message, offset) {
    super(message);
    this.offset = offset;
  }
}

// parse(text) -> node.  A node is {kind, start, end, value} with
// kind "object" (members: [{key, keyStart, keyEnd, node}]), "array"
// (items: [node]), "string", "number" or "literal".  Throws JsonSyntaxError.
export function parse(text) {
  let i = 0;
  const n = text.length;
  const ws = () => {
    while (i < n) {
      const c = text.charCodeAt(i);
      if (c === 0x20 || c === 0x0a || c === 0x0d || c === 0x09) i++;
      else break;
    }
  };
  const fail = (msg) => {
    throw new JsonSyntaxError(msg, Math.min(i, n));
  };
  const str = () => {
    const start = i++;
    let out = "";
    for (;;) {
      if (i >= n) fail("unterminated string");
      const c = text[i];
      if (c === '"') break;
      if (c === "\\") {
        const e = text[i + 1];
        const map = { '"': '"', "\\": "\\", "/": "/", b: "\b", f: "\f", n: "\n", r: "\r", t: "\t" };
        if (e in map) {
          out += map[e];
          i += 2;
        } else if (e === "u" && /^[0-9a-fA-F]{4}$/.test(text.slice(i + 2, i + 6))) {
          out += String.fromCharCode(parseInt(text.slice(i + 2, i + 6), 16));
          i += 6;
        } else fail("bad escape in string");
      } else if (c < " ") {
        fail("control character in string");
      } else {
        // a run of plain characters at once: an embedded model's base64 is
        // megabytes long, and one concatenation per character is slow
        let j = i + 1;
        while (j < n) {
          const d = text.charCodeAt(j);
          if (d === 0x22 || d === 0x5c || d < 0x20) break;
          j++;
        }
        out += text.slice(i, j);
        i = j;
      }
    }
    i++;
    return { kind: "string", start, end: i, value: out };
  };
  const value = (depth) => {
    if (depth > 512) fail("nested too deeply");
    ws();
    if (i >= n) fail("unexpected end of input");
    const c = text[i];
    const start = i;
    if (c === "{") {
      i++;
      const members = [];
      const obj = {};
      ws();
      if (text[i] === "}") {
        i++;
        return { kind: "object", start, end: i, members, value: obj };
      }
      for (;;) {
        ws();
        if (text[i] !== '"') fail("expected a key string");
        const k = str();
        ws();
        if (text[i] !== ":") fail("expected ':'");
        i++;
        const v = value(depth + 1);
        members.push({ key: k.value, keyStart: k.start, keyEnd: k.end, node: v });
        Object.defineProperty(obj, k.value, { value: v.value, enumerable: true, configurable: true, writable: true });
        ws();
        if (text[i] === ",") {
          i++;
          continue;
        }
        if (text[i] === "}") {
          i++;
          return { kind: "object", start, end: i, members, value: obj };
        }
        fail("expected ',' or '}'");
      }
    }
    if (c === "[") {
      i++;
      const items = [];
      ws();
      if (text[i] === "]") {
        i++;
        return { kind: "array", start, end: i, items, value: [] };
      }
      for (;;) {
        items.push(value(depth + 1));
        ws();
        if (text[i] === ",") {
          i++;
          continue;
        }
        if (text[i] === "]") {
          i++;
          return { kind: "array", start, end: i, items, value: items.map((x) => x.value) };
        }
        fail("expected ',' or ']'");
      }
    }
    if (c === '"') return str();
    const m = /^-?(?:0|[1-9]\d*)(?:\.\d+)?(?:[eE][+-]?\d+)?/.exec(text.slice(i, i + 400));
    if (m && m[0].length) {
      i += m[0].length;
      return { kind: "number", start, end: i, value: Number(m[0]) };
    }
    for (const [lit, v] of [["true", true], ["false", false], ["null", null]]) {
      if (text.startsWith(lit, i)) {
        i += lit.length;
        return { kind: "literal", start, end: i, value: v };
      }
    }
    return fail("unexpected character");
  };
  const root = value(0);
  ws();
  if (i < n) fail("unexpected text after the JSON value");
  return root;
}

// The member of an object node named key (the last one when repeated: the
// server reports a duplicate at its second occurrence).
export function member(node, key) {
  if (!node || node.kind !== "object") return null;
  for (let k = node.members.length - 1; k >= 0; k--) if (node.members[k].key === key) return node.members[k];
  return null;
}

export function splitPointer(ptr) {
  if (!ptr || ptr === "/") return ptr === "/" ? [""] : [];
  return ptr
    .split("/")
    .slice(1)
    .map((s) => s.replace(/~1/g, "/").replace(/~0/g, "~"));
}

// The member a pointer's segment names.  rayd shows a key longer than 64
// bytes cut, with "..." (core/format/json_pointer.c): such a segment names the
// first longer key it begins (the first in the text the checks meet).
function memberOf(node, seg) {
  const m = member(node, seg);
  if (m || !seg.endsWith("...")) return m;
  const cut = seg.slice(0, -3);
  return node.members.find((x) => x.key.length > cut.length && x.key.startsWith(cut)) || null;
}

// The text offset a JSON Pointer names: the key of an object member, the
// start of an array element; as deep as the pointer resolves (an error
// about a missing value points at its parent).
export function pointerOffset(root, ptr) {
  let node = root;
  let off = root.start;
  for (const seg of splitPointer(ptr)) {
    if (node.kind === "object") {
      const m = memberOf(node, seg);
      if (!m) break;
      off = m.keyStart;
      node = m.node;
    } else if (node.kind === "array" && /^(0|[1-9]\d*)$/.test(seg) && +seg < node.items.length) {
      node = node.items[+seg];
      off = node.start;
    } else break;
  }
  return off;
}

export function lineOf(text, offset) {
  let line = 1;
  for (let k = 0; k < offset && k < text.length; k++) if (text.charCodeAt(k) === 10) line++;
  return line;
}

// The offset of (line, column), both from 1, as rayd counts them: a column
// is a character (a code point), while the text's offsets count UTF-16
// units, two for a character beyond U+FFFF (an emoji in a name), so the
// columns are walked, not added.  Never past the line's end.
export function offsetOfLine(text, line, column = 1) {
  let off = 0;
  for (let l = 1; l < line; l++) {
    const nl = text.indexOf("\n", off);
    if (nl < 0) return text.length;
    off = nl + 1;
  }
  for (let c = 1; c < column && off < text.length && text[off] !== "\n"; c++)
    off += text.codePointAt(off) > 0xffff ? 2 : 1;
  return off;
}

export function fmtNumber(x) {
  const r = Math.round(x * 1e4) / 1e4;
  return String(Object.is(r, -0) ? 0 : r);
}

export function fmtVector(v) {
  return "[" + v.map(fmtNumber).join(", ") + "]";
}

// Sets path (["camera", "position"]) to valueText in the text, keeping the
// rest of it byte for byte.  Missing objects on the way are inserted.
export function replaceAt(text, root, path, valueText) {
  let node = root;
  for (let d = 0; d < path.length; d++) {
    if (node.kind !== "object") throw new Error("not an object at /" + path.slice(0, d).join("/"));
    const m = member(node, path[d]);
    if (!m) {
      let v = valueText;
      for (let e = path.length - 1; e > d; e--) v = `{"${path[e]}": ${v}}`;
      const ins = `"${path[d]}": ${v}` + (node.members.length ? ", " : "");
      return text.slice(0, node.start + 1) + ins + text.slice(node.start + 1);
    }
    node = m.node;
  }
  return text.slice(0, node.start) + valueText + text.slice(node.end);
}

// Pretty-prints a value: anything whose one-line form fits in the width
// stays on one line, the rest is indented by two spaces.
export function format(value, width = 100) {
  const one = (v) => {
    if (Array.isArray(v)) return "[" + v.map(one).join(", ") + "]";
    if (v && typeof v === "object")
      return (
        "{" +
        Object.keys(v)
          .map((k) => JSON.stringify(k) + ": " + one(v[k]))
          .join(", ") +
        "}"
      );
    return JSON.stringify(v);
  };
  const go = (v, ind) => {
    const flat = one(v);
    if (flat.length + ind.length <= width || !v || typeof v !== "object") return flat;
    const ind2 = ind + "  ";
    if (Array.isArray(v)) {
      if (v.every((x) => typeof x !== "object" || x === null)) {
        // long arrays of numbers (meshes): wrap them like text
        const lines = [];
        let cur = "";
        for (const x of v.map(one)) {
          if (cur && ind2.length + cur.length + x.length + 2 > width) {
            lines.push(cur + ",");
            cur = "";
          }
          cur += (cur ? ", " : "") + x;
        }
        lines.push(cur);
        return "[\n" + lines.map((l) => ind2 + l).join("\n") + "\n" + ind + "]";
      }
      return "[\n" + v.map((x) => ind2 + go(x, ind2)).join(",\n") + "\n" + ind + "]";
    }
    return (
      "{\n" +
      Object.keys(v)
        .map((k) => ind2 + JSON.stringify(k) + ": " + go(v[k], ind2))
        .join(",\n") +
      "\n" +
      ind +
      "}"
    );
  };
  return go(value, "") + "\n";
}
