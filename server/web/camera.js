// camera.js -- orbit and dolly of the scene's camera around camera.look_at.
//
// The camera is the paper's: position C, look_at F, up.  Orbiting keeps F and
// the distance |C - F| and moves C on the sphere around F: a horizontal drag
// turns it about the up axis, a vertical one tilts it towards or away from
// up (stopping short of the pole, where the view would be parallel to up and
// the scene invalid).  The wheel scales the distance.  Both take a floor:
// the lowest height along up the eye may reach (ground.js finds it); a
// move stops there, but never lifts an eye that started below it.  Defaults
// are the scene format's: position [0,0,0], look_at [0,0,-1], up [0,1,0].
// A camera the renderer places ("frame": "all", a gltf object's "camera")
// is not moved: the scene may not give a position beside it.

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const len = (a) => Math.sqrt(dot(a, a));
const norm = (a) => mul(a, 1 / (len(a) || 1));

const isVec = (v) => Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === "number" && isFinite(x));

// Does a gltf object of the scene choose one of its file's cameras?  That
// camera then places the scene's, which may add only aperture and
// focus_distance; where the file's camera is, the page cannot know.
const gltfCamera = (scene) =>
  Array.isArray(scene.objects) && scene.objects.some((o) => o && o.type === "gltf" && o.camera !== undefined);

// The camera of a parsed scene with the defaults filled in, or null when it
// is not one the controls can move (missing pieces are defaulted).
export function cameraOf(scene) {
  const cam = (scene && typeof scene === "object" && scene.camera) || {};
  if (typeof cam !== "object" || Array.isArray(cam)) return null;
  if (cam.frame !== undefined) return null; // placed by the renderer ("frame": "all"): no orbit
  if (gltfCamera(scene)) return null; // placed by the file's camera: position is refused beside it
  const position = cam.position === undefined ? [0, 0, 0] : cam.position;
  const lookAt = cam.look_at === undefined ? [0, 0, -1] : cam.look_at;
  const up = cam.up === undefined ? [0, 1, 0] : cam.up;
  if (!isVec(position) || !isVec(lookAt) || !isVec(up) || len(up) === 0) return null;
  if (len(sub(position, lookAt)) < 1e-9) return null;
  return { position, lookAt, up };
}

// The new position after a drag of (dx, dy) radians.
export function orbit(cam, dx, dy, floor = -Infinity) {
  const up = norm(cam.up);
  const off = sub(cam.position, cam.lookAt);
  const r = len(off);
  // a basis around up: e1, e2 span the plane perpendicular to it
  let e1 = sub(off, mul(up, dot(off, up)));
  if (len(e1) < 1e-9 * r) e1 = Math.abs(up[0]) < 0.9 ? cross(up, [1, 0, 0]) : cross(up, [0, 1, 0]);
  e1 = norm(e1);
  const e2 = cross(up, e1);
  let theta = Math.acos(Math.max(-1, Math.min(1, dot(off, up) / r))); // angle from up
  let phi = 0; // e1 is where the camera is now
  phi -= dx;
  let lowest = Math.PI - 0.02; // the largest angle from up
  const c = (floor - dot(cam.lookAt, up)) / r; // cos of the angle where the eye meets the floor
  if (c > -1) lowest = Math.min(lowest, Math.max(Math.acos(Math.min(1, c)), theta));
  theta = Math.max(0.02, Math.min(lowest, theta - dy));
  const s = Math.sin(theta);
  const dir = add(add(mul(e1, s * Math.cos(phi)), mul(e2, s * Math.sin(phi))), mul(up, Math.cos(theta)));
  return add(cam.lookAt, mul(dir, r));
}

// The new position after scaling the distance to look_at by factor.
export function dolly(cam, factor, floor = -Infinity) {
  const off = sub(cam.position, cam.lookAt);
  const r = len(off);
  let nr = Math.max(1e-3, Math.min(1e8, r * factor));
  const down = -dot(off, norm(cam.up)) / r; // > 0: the eye is below look_at
  if (down > 0 && nr > r) nr = Math.min(nr, Math.max(r, (dot(cam.lookAt, norm(cam.up)) - floor) / down));
  return add(cam.lookAt, mul(off, nr / r));
}
