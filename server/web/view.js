// view.js -- how large the canvas is shown: fitted to the stage, or 1:1.
//
// The canvas always holds the image at its own size; only its CSS size
// changes.  Fitted, it is scaled to fill the stage.  At 1:1 one pixel of the
// image is one pixel of the screen, which is what judging noise, aliasing
// or a fine texture needs: the CSS size is the image size divided by
// devicePixelRatio, and the stage scrolls when the image is larger.  The
// ratio changes with the browser's zoom or when the window moves to another
// screen; a media query on the current ratio notices that.

export class View {
  constructor(stage, canvas) {
    this.stage = stage;
    this.canvas = canvas;
    this.oneToOne = false;
    this.onToggle = null;
    new ResizeObserver(() => this.apply()).observe(stage);
    this.watchRatio();
  }

  toggle(on = !this.oneToOne) {
    this.oneToOne = on;
    this.stage.classList.toggle("one-to-one", on);
    this.apply();
    if (this.onToggle) this.onToggle(on);
  }

  apply() {
    const c = this.canvas;
    if (this.oneToOne) {
      const dpr = window.devicePixelRatio || 1;
      c.style.width = `${c.width / dpr}px`;
      c.style.height = `${c.height / dpr}px`;
      return;
    }
    const cs = getComputedStyle(this.stage);
    const w = this.stage.clientWidth - parseFloat(cs.paddingLeft) - parseFloat(cs.paddingRight);
    const h = this.stage.clientHeight - parseFloat(cs.paddingTop) - parseFloat(cs.paddingBottom);
    const k = Math.max(0.05, Math.min(w / c.width, h / c.height));
    c.style.width = `${Math.floor(c.width * k)}px`;
    c.style.height = `${Math.floor(c.height * k)}px`;
  }

  watchRatio() {
    const mq = matchMedia(`(resolution: ${window.devicePixelRatio || 1}dppx)`);
    mq.addEventListener(
      "change",
      () => {
        this.apply();
        this.watchRatio();
      },
      { once: true }
    );
  }
}
