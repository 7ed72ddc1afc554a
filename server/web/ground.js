// ground.js -- how low the camera controls may take the eye.
//
// Orbiting down past the floor puts the eye under it: the picture becomes
// the underside of an infinite plane, and it takes a drag back to find the
// scene again.  So the orbit (and the dolly) stop just above the ground
// unless asked to go under (the page's "under" box, or Shift held).
//
// Heights are measured along the scene's up vector.  The ground is the
// highest plane below look_at that faces up or down: a top-level "plane"
// object with no transform whose normal is within 30 degrees of up (a
// tilted one counts at its height straight under look_at).  Planes are
// infinite, so that is the one the eye would cross first on its way down
// (a lower one is hidden under it).  A scene with no such plane has its
// ground at height 0 (y = 0 when up is +y), or at look_at's own height when
// look_at is not above 0.  The eye keeps a margin of a thousandth of its
// distance to look_at above the ground.

const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const isVec = (v) => Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === "number" && isFinite(x));
const unit = (a) => {
  const l = Math.sqrt(dot(a, a));
  return l > 0 ? [a[0] / l, a[1] / l, a[2] / l] : null;
};

// The ground's height along the unit up vector of cam (from cameraOf).
export function groundHeight(scene, cam) {
  const up = unit(cam.up);
  const lookLevel = dot(cam.lookAt, up);
  const objects = scene && Array.isArray(scene.objects) ? scene.objects : [];
  let best = -Infinity;
  for (const o of objects) {
    if (!o || typeof o !== "object" || o.type !== "plane" || o.transform !== undefined) continue;
    const point = o.point === undefined ? [0, 0, 0] : o.point;
    const n = unit(o.normal === undefined ? [0, 1, 0] : isVec(o.normal) ? o.normal : [0, 0, 0]);
    if (!isVec(point) || !n || Math.abs(dot(n, up)) < Math.cos(Math.PI / 6)) continue;
    // the plane's height straight under (or over) look_at
    const h = lookLevel - (dot(n, cam.lookAt) - dot(n, point)) / dot(n, up);
    if (h < lookLevel && h > best) best = h;
  }
  if (best > -Infinity) return best;
  return Math.min(0, lookLevel);
}

// The lowest height along up the eye may have in scene.
export function eyeFloor(scene, cam) {
  const d = cam.position.map((x, k) => x - cam.lookAt[k]);
  return groundHeight(scene, cam) + 1e-3 * Math.sqrt(dot(d, d));
}
