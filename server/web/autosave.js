// autosave.js -- the editor's text kept in the browser's local storage.
//
// A reload, a closed tab or a crash should not lose a scene someone spent
// an hour on, so every change of the text is written at once (a scene is a
// few kilobytes; writing it is cheaper than one frame of the orbit) and the
// page opens with it.  The example the text came from is kept beside it, so
// the menu shows it again, and whether the text was edited: an example left
// as it was opens as the example is now (a newer rayd may have changed it).
// A scene from a link that the user has not rendered is saved as such
// (linked), so that opening the page again does not render it either.
// Storage full or turned off: the page works as before, without it.

const KEY = "rayd.scene";

// {text, example, edited, linked} of the last visit, or null.
export function loadSaved() {
  try {
    const v = JSON.parse(localStorage.getItem(KEY));
    if (v && typeof v.text === "string")
      return { text: v.text, example: String(v.example || ""), edited: v.edited !== false, linked: v.linked === true };
  } catch (_) {
    /* nothing usable saved */
  }
  return null;
}

export function save(text, example, edited, linked = false) {
  try {
    localStorage.setItem(KEY, JSON.stringify({ text, example, edited, linked }));
  } catch (_) {
    /* full or not allowed: nothing kept */
  }
}
