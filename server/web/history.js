// history.js -- the editor's undo history, kept by the page, not the browser.
//
// The browser's own undo in a textarea loses its steps as soon as a script
// sets the text, and the page sets it often: a camera drag rewrites
// "position" at every mouse move, an example replaces the whole scene.  So
// every change of the text, typed or made by the page, is recorded here, and
// Ctrl+Z / Ctrl+Y walk this list instead of the browser's.
//
// A state is {text, kind, group, label}: the text after a change, what made
// it ("typing", "camera", "example" ...), an optional group, and a label the
// page keeps with it (the example the text came from).  record() adds a
// state after the current one and drops the states that were undone.  When
// the new state has the same group as the current one, it replaces it
// instead: one drag, or one word typed, is one step.  After an undo or redo
// (or seal()) the current state is sealed and never replaced, so a new
// change always makes a new step.

export class TextHistory {
  constructor(text = "", limit = 100) {
    this.limit = limit;
    this.reset(text);
  }

  reset(text, label = "") {
    this.states = [{ text, kind: "open", group: null, label }];
    this.i = 0;
    this.sealed = true;
  }

  get current() {
    return this.states[this.i];
  }

  canUndo() {
    return this.i > 0;
  }

  canRedo() {
    return this.i < this.states.length - 1;
  }

  // Records text as the newest state; false when it is the current text.
  record(text, { kind = "edit", group = null, label = "" } = {}) {
    const cur = this.states[this.i];
    if (text === cur.text) return false;
    this.states.length = this.i + 1;
    if (!this.sealed && group !== null && cur.group === group && this.i > 0) {
      this.states[this.i] = { text, kind, group, label };
      return true;
    }
    this.states.push({ text, kind, group, label });
    this.i++;
    if (this.states.length > this.limit) {
      this.states.shift();
      this.i--;
    }
    this.sealed = false;
    return true;
  }

  seal() {
    this.sealed = true;
  }

  // {text, kind, label}: the text to show, the kind of the change undone and
  // the label of the state now current, or null when there is nothing to undo.
  undo() {
    if (!this.canUndo()) return null;
    const undone = this.states[this.i--];
    this.sealed = true;
    const now = this.states[this.i];
    return { text: now.text, kind: undone.kind, label: now.label };
  }

  redo() {
    if (!this.canRedo()) return null;
    const redone = this.states[++this.i];
    this.sealed = true;
    return { text: redone.text, kind: redone.kind, label: redone.label };
  }
}

// Where b differs from a: the common prefix's length and the end of the
// changed part in b (for the caret after an undo).
export function changedRange(a, b) {
  const n = Math.min(a.length, b.length);
  let p = 0;
  while (p < n && a.charCodeAt(p) === b.charCodeAt(p)) p++;
  let s = 0;
  while (s < n - p && a.charCodeAt(a.length - 1 - s) === b.charCodeAt(b.length - 1 - s)) s++;
  return { start: p, end: b.length - s };
}
