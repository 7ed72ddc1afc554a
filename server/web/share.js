// share.js -- a link that reopens a scene: #scene=<id>&z=<data>.
//
// rayd keeps compiled scenes, not their text, and has no endpoint that gives
// a scene's JSON back for its id, so the link carries the text itself in the
// URL fragment (never sent to the server): z= is the base64url of the
// deflate-raw compressed text (CompressionStream), j= the base64url of the
// plain text where that is missing.  The id (the SHA-256 the server gave for
// these bytes, as sha256sum gives it) names the scene for people and is
// checked on opening, where the page may hash (crypto.subtle: a secure
// context, as localhost is): a link altered or cut short is then refused
// with a reason, never opened as another scene.

const b64url = (bytes) => {
  let s = "";
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  return btoa(s).replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "");
};
const unb64url = (s) => {
  const b = atob(s.replace(/-/g, "+").replace(/_/g, "/"));
  const out = new Uint8Array(b.length);
  for (let i = 0; i < b.length; i++) out[i] = b.charCodeAt(i);
  return out;
};

async function pipe(bytes, stream) {
  const out = new Response(new Blob([bytes]).stream().pipeThrough(stream));
  return new Uint8Array(await out.arrayBuffer());
}

export async function linkFor(id, text) {
  const raw = new TextEncoder().encode(text);
  if (typeof CompressionStream === "function")
    return `#scene=${id}&z=${b64url(await pipe(raw, new CompressionStream("deflate-raw")))}`;
  return `#scene=${id}&j=${b64url(raw)}`;
}

// {id, text} from a location.hash, or null when it holds no scene.  Throws
// an Error saying which part of the link is wrong.
export async function fromHash(hash) {
  const p = new URLSearchParams(hash.replace(/^#/, ""));
  const data = p.get("z") || p.get("j");
  if (!data) return null;
  let bytes;
  try {
    bytes = unb64url(data);
  } catch {
    throw new Error(`its ${p.get("z") ? "z" : "j"}= is not base64url`);
  }
  if (p.get("z")) {
    try {
      bytes = await pipe(bytes, new DecompressionStream("deflate-raw"));
    } catch {
      throw new Error("its z= does not inflate: cut short or altered");
    }
  }
  let text;
  try {
    text = new TextDecoder("utf-8", { fatal: true }).decode(bytes);
  } catch {
    throw new Error("its scene is not UTF-8 text");
  }
  const id = p.get("scene") || "";
  const sum = id ? await sha256hex(text) : "";
  if (sum && sum !== id.toLowerCase())
    throw new Error(`its scene is not the one its id names (scene=${id.slice(0, 12)}…): altered`);
  return { id, text };
}

export async function sha256hex(text) {
  if (!crypto.subtle) return "";
  const d = await crypto.subtle.digest("SHA-256", new TextEncoder().encode(text));
  return [...new Uint8Array(d)].map((b) => b.toString(16).padStart(2, "0")).join("");
}
