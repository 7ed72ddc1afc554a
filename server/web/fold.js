// fold.js -- long strings of a scene kept out of the editor's text.
//
// A model opened in the page is embedded in the scene as a string of up to
// --max-body bytes (base64, or an OBJ's text), all on one line.  In the
// editor's textarea such a line costs Chromium seconds to lay out at each
// change (2 MB: 6.5 s to show, 1.3 s for each keystroke or camera move),
// and each step of the undo history would keep a copy.  So the editor
// shows, in place of every string longer than FOLD_MIN characters, a short
// token of its own, "<2097152 characters of pond.ply #3, kept by the page
// and sent in their place>", and the page keeps the string.  Every text that
// leaves the page -- a render, a job, a link, the JSON download, the
// autosave -- is unfolded first, so the server, a link or a file always
// gets the real scene; the editor's JSON is the same tree, so a JSON Pointer
// of the server's still finds its line.  A token moved or copied in the
// editor unfolds wherever it is; one the page does not know (typed, or of
// another visit) is sent as it is and the server refuses it as base64 or
// geometry, at its place.  Strings are kept as their JSON text (escapes
// and all), so folding and unfolding are plain text replacements.

export const FOLD_MIN = 32768;
const kept = new Map(); // token -> the JSON text of the string's content
let serial = 0;
const TOKEN = /<\d+ characters of [^<>"\\]* #\d+, kept by the page and sent in their place>/g;

// A token for a string's JSON content (without its quotes).
function tokenFor(json, what) {
  const label = String(what || "data").replace(/[^\w .+-]/g, "_").slice(0, 80);
  const t = `<${json.length} characters of ${label} #${++serial}, kept by the page and sent in their place>`;
  kept.set(t, json);
  return t;
}

// The value to put in a scene object for the string s: s itself when short,
// else a token the page keeps it under.
export function folded(s, what) {
  return s.length < FOLD_MIN ? s : tokenFor(JSON.stringify(s).slice(1, -1), what);
}

// text with every string of FOLD_MIN characters or more replaced by a token.
export function fold(text) {
  if (text.length < FOLD_MIN) return text;
  return text.replace(/"([^"\\]*(?:\\.[^"\\]*)*)"/g, (m, body) => (body.length < FOLD_MIN ? m : `"${tokenFor(body)}"`));
}

// text with every token the page knows replaced by its string.
export function unfold(text) {
  if (!text.includes(" kept by the page and sent in their place>")) return text;
  return text.replace(TOKEN, (t) => (kept.has(t) ? kept.get(t) : t));
}
