// share.js -- a link that reopens a scene: #scene=<id>&z=<data>.
//
// rayd keeps compiled scenes, not their text, and has no endpoint that gives
// a scene's JSON back for its id, so the link carries the text itself in the
// URL fragment (never sent to the server): z= is the base64url of the
// deflate-raw compressed text (CompressionStream), j= the base64url of the
// plain text where that is missing.  The id (the SHA-256 the server gave for
// these bytes) names the scene for people and is checked on opening.

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

// {id, text} from a location.hash, or null when it holds no scene.
export async function fromHash(hash) {
  const p = new URLSearchParams(hash.replace(/^#/, ""));
  let bytes = null;
  if (p.get("z")) bytes = await pipe(unb64url(p.get("z")), new DecompressionStream("deflate-raw"));
  else if (p.get("j")) bytes = unb64url(p.get("j"));
  if (!bytes) return null;
  return { id: p.get("scene") || "", text: new TextDecoder("utf-8", { fatal: true }).decode(bytes) };
}

export async function sha256hex(text) {
  if (!crypto.subtle) return "";
  const d = await crypto.subtle.digest("SHA-256", new TextEncoder().encode(text));
  return [...new Uint8Array(d)].map((b) => b.toString(16).padStart(2, "0")).join("");
}
