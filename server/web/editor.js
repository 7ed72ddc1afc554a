// editor.js -- a textarea with line numbers, one highlighted error line and
// the page's own undo history.
//
// The textarea does not wrap, so line k of the text is line k on screen and
// the gutter (a column of numbers) and the error band can be placed by
// arithmetic: top = (k - 1) * line height - scrollTop.  Tab inserts two
// spaces.  Every change of the text -- typed, or set by the page (a camera
// move, an example) -- goes into a TextHistory (history.js), and Ctrl+Z,
// Ctrl+Shift+Z / Ctrl+Y and the menu's Undo walk it, so the page's changes
// are undone like typing.  onChange(fn) hears of every change:
// fn({source: "input" | "set" | "undo" | "redo", kind}).  label (the page's
// name for where the text came from) is kept with each step and comes back
// with it.

import { TextHistory, changedRange } from "./history.js";

export class Editor {
  constructor(root) {
    this.root = root;
    this.ta = root.querySelector("textarea");
    this.gutter = root.querySelector(".gutter");
    this.band = root.querySelector(".errband");
    this.errorLine = 0;
    this.lines = 0;
    this.label = "";
    this.history = new TextHistory(this.ta.value);
    this.listeners = [];
    this.typingRun = 0; // typing is grouped by runs: a word, a run of deletes
    this.typed = null; // {cls, caret} of the last typed change
    this.before = null; // the selection before the change being typed
    this.ta.addEventListener("beforeinput", (e) => {
      if (e.inputType === "historyUndo" || e.inputType === "historyRedo") {
        e.preventDefault();
        if (e.inputType === "historyUndo") this.undo();
        else this.redo();
        return;
      }
      this.before = { start: this.ta.selectionStart, end: this.ta.selectionEnd };
    });
    this.ta.addEventListener("input", (e) => this.typedChange(e));
    this.ta.addEventListener("scroll", () => this.sync());
    this.ta.addEventListener("keydown", (e) => {
      if (e.key === "Tab" && !e.ctrlKey && !e.metaKey && !e.altKey && !e.shiftKey) {
        e.preventDefault();
        document.execCommand("insertText", false, "  ");
        return;
      }
      const step = undoKey(e);
      if (step) {
        e.preventDefault();
        if (step === "undo") this.undo();
        else this.redo();
      }
    });
    new ResizeObserver(() => this.sync()).observe(this.ta);
    this.refresh();
  }

  get value() {
    return this.ta.value;
  }

  onChange(fn) {
    this.listeners.push(fn);
  }

  emit(info) {
    for (const fn of this.listeners) fn(info);
  }

  // A change typed in the textarea: letters of one word (or one run of
  // deletes at the caret) are one step; a space, a newline, a paste, a jump
  // of the caret start another.
  typedChange(e) {
    const t = e.inputType || "";
    const cls =
      t === "insertText" && e.data && !/\s/.test(e.data)
        ? "ins"
        : t === "deleteContentBackward" || t === "deleteContentForward"
          ? "del"
          : null;
    const b = this.before;
    const joins = cls && this.typed && this.typed.cls === cls && b && b.start === b.end && b.start === this.typed.caret;
    if (!joins) this.typingRun++;
    this.history.record(this.ta.value, {
      kind: "typing",
      group: cls ? "typing" + this.typingRun : null,
      label: this.label,
    });
    this.typed = cls ? { cls, caret: this.ta.selectionStart } : null;
    this.before = null;
    this.refresh();
    this.emit({ source: "input", kind: "typing" });
  }

  // Replaces the text, as one step of the undo history.  keep=true keeps
  // the caret and scroll (camera moves); kind says what the change is (the
  // page renders again when a camera move or an example is undone); changes
  // of the same group are one step (the moves of one drag).
  set(text, { keep = false, kind = "set", group = null } = {}) {
    this.show(text, keep);
    this.typed = null;
    this.history.record(text, { kind, group, label: this.label });
    this.emit({ source: "set", kind });
  }

  // Replaces the text and forgets the history (the page's first text).
  reset(text) {
    this.show(text, false);
    this.typed = null;
    this.history.reset(text, this.label);
  }

  // Makes the next change a new step of the history.
  seal() {
    this.history.seal();
  }

  undo() {
    return this.step(this.history.undo(), "undo");
  }

  redo() {
    return this.step(this.history.redo(), "redo");
  }

  // Shows the text of an undo or redo, the caret at the end of what changed.
  step(got, source) {
    if (!got) return false;
    const { start, end } = changedRange(this.ta.value, got.text);
    this.show(got.text, true);
    this.ta.setSelectionRange(end, end);
    this.typed = null;
    this.label = got.label;
    const line = got.text.slice(0, start).split("\n").length;
    const lh = this.lineHeight();
    const top = (line - 1) * lh;
    if (top < this.ta.scrollTop || top + lh > this.ta.scrollTop + this.ta.clientHeight)
      this.ta.scrollTop = Math.max(0, top - this.ta.clientHeight / 3);
    this.sync();
    this.emit({ source, kind: got.kind });
    return true;
  }

  show(text, keep) {
    if (keep) {
      const { selectionStart: a, scrollTop: st, scrollLeft: sl } = this.ta;
      this.ta.value = text;
      this.ta.selectionStart = this.ta.selectionEnd = Math.min(a, text.length);
      this.ta.scrollTop = st;
      this.ta.scrollLeft = sl;
    } else {
      this.ta.value = text;
      this.ta.scrollTop = 0;
      this.ta.selectionStart = this.ta.selectionEnd = 0;
    }
    this.refresh();
  }

  lineHeight() {
    return parseFloat(getComputedStyle(this.ta).lineHeight) || 20;
  }

  refresh() {
    const n = this.ta.value.split("\n").length;
    if (this.errorLine > n) this.errorLine = 0;
    if (n !== this.lines || this.gutterErr !== this.errorLine) {
      this.lines = n;
      this.gutterErr = this.errorLine;
      const frag = document.createDocumentFragment();
      for (let k = 1; k <= n; k++) {
        const d = document.createElement("div");
        d.textContent = k;
        if (k === this.errorLine) d.className = "err";
        frag.appendChild(d);
      }
      const pad = document.createElement("div");
      pad.className = "pad";
      frag.appendChild(pad);
      this.gutter.replaceChildren(frag);
    }
    this.sync();
  }

  sync() {
    this.gutter.scrollTop = this.ta.scrollTop;
    if (this.errorLine) {
      const lh = this.lineHeight();
      const padTop = parseFloat(getComputedStyle(this.ta).paddingTop) || 0;
      this.band.style.transform = `translateY(${padTop + (this.errorLine - 1) * lh - this.ta.scrollTop}px)`;
      this.band.style.height = lh + "px";
      this.band.hidden = false;
    } else this.band.hidden = true;
  }

  markError(line) {
    this.errorLine = line || 0;
    this.root.dataset.errorLine = String(this.errorLine);
    this.refresh();
    if (this.errorLine) {
      // scroll the marked line into view (without taking the focus)
      const lh = this.lineHeight();
      const top = (this.errorLine - 1) * lh;
      const st = this.ta.scrollTop;
      if (top < st || top + 2 * lh > st + this.ta.clientHeight) {
        this.ta.scrollTop = Math.max(0, top - this.ta.clientHeight / 3);
        this.sync();
      }
    }
  }

  // The width of one character of the textarea's (monospace) font.
  charWidth() {
    if (!this.measure) this.measure = document.createElement("canvas").getContext("2d");
    const cs = getComputedStyle(this.ta);
    this.measure.font = `${cs.fontSize} ${cs.fontFamily}`;
    return this.measure.measureText("0").width || 7.5;
  }

  // The caret at offset, scrolled into view: its line in the middle, and,
  // since lines do not wrap, its column too when it is past either edge.
  reveal(offset) {
    const before = this.ta.value.slice(0, offset);
    const line = before.split("\n").length;
    this.ta.focus({ preventScroll: true });
    this.ta.setSelectionRange(offset, offset);
    const lh = this.lineHeight();
    this.ta.scrollTop = Math.max(0, (line - 1) * lh - this.ta.clientHeight / 2 + lh);
    const cw = this.charWidth();
    const x = (offset - before.lastIndexOf("\n") - 1) * cw; // from the text's left edge
    const pad = parseFloat(getComputedStyle(this.ta).paddingLeft) || 0;
    const view = this.ta.clientWidth - 2 * pad;
    if (x < this.ta.scrollLeft || x + 12 * cw > this.ta.scrollLeft + view)
      this.ta.scrollLeft = Math.max(0, x - view / 3);
    this.sync();
  }
}

// "undo", "redo" or null for a key event: Ctrl+Z, Ctrl+Shift+Z, Ctrl+Y
// (Cmd on a Mac).
export function undoKey(e) {
  if (!(e.ctrlKey || e.metaKey) || e.altKey) return null;
  const k = e.key.toLowerCase();
  if (k === "z") return e.shiftKey ? "redo" : "undo";
  if (k === "y" && !e.shiftKey) return "redo";
  return null;
}
