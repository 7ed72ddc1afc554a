// editor.js -- a textarea with line numbers and one highlighted error line.
//
// The textarea does not wrap, so line k of the text is line k on screen and
// the gutter (a column of numbers) and the error band can be placed by
// arithmetic: top = (k - 1) * line height - scrollTop.  Tab inserts two
// spaces; everything else is the browser's own editing, undo included.

export class Editor {
  constructor(root) {
    this.root = root;
    this.ta = root.querySelector("textarea");
    this.gutter = root.querySelector(".gutter");
    this.band = root.querySelector(".errband");
    this.errorLine = 0;
    this.lines = 0;
    this.ta.addEventListener("input", () => this.refresh());
    this.ta.addEventListener("scroll", () => this.sync());
    this.ta.addEventListener("keydown", (e) => {
      if (e.key === "Tab" && !e.ctrlKey && !e.metaKey && !e.altKey && !e.shiftKey) {
        e.preventDefault();
        document.execCommand("insertText", false, "  ");
      }
    });
    new ResizeObserver(() => this.sync()).observe(this.ta);
    this.refresh();
  }

  get value() {
    return this.ta.value;
  }

  // Replaces the text; keep=true keeps the caret and scroll (camera moves),
  // and goes through execCommand so Ctrl+Z undoes it.
  set(text, keep = false) {
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

  // Moves the caret to an offset and scrolls it into the middle of the view.
  reveal(offset) {
    const before = this.ta.value.slice(0, offset);
    const line = before.split("\n").length;
    this.ta.focus({ preventScroll: true });
    this.ta.setSelectionRange(offset, offset);
    const lh = this.lineHeight();
    this.ta.scrollTop = Math.max(0, (line - 1) * lh - this.ta.clientHeight / 2 + lh);
    this.sync();
  }
}
