#!/usr/bin/env bash
# Every benchmark scene, rendered small, gives the same image through the
# BVH as by brute force: the generated meshes (as `make bench` makes them,
# smaller levels), the 10x10-sphere Whitted scene and the example scenes.
set -u
cd "$RAYD_ROOT"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
for level in 2 4 5; do
    "$RAYD_BUILD/bench/genmesh" "$level" "$T/mesh-$level.ply" || echo "FAIL genmesh-$level: exit $?"
    cat >"$T/mesh-$level.json" <<JSON
{"camera": {"position": [0.3, 0.4, 3.2], "look_at": [0, 0, 0], "fov_x": 50},
 "lights": [{"type": "point", "position": [4, 5, 6]}],
 "objects": [{"type": "mesh", "source": {"file": "mesh-$level.ply"}, "smooth": false,
              "material": {"color": [0.8, 0.7, 0.6], "reflectivity": 0.2}},
             {"type": "mesh", "source": {"file": "mesh-$level.ply"}, "transform": {"scale": 0.5, "translate": [1.2, 0.3, -1]}}]}
JSON
    "$RAYD_BUILD/tests/tools/bvhcheck" "$T/mesh-$level.json"
done
for s in bench/scenes/*.json scenes/*.json; do
    [ -f "$s" ] || continue
    "$RAYD_BUILD/tests/tools/bvhcheck" "$s" 64 40
done

# Coincident surfaces, some through transforms (z-fighting on purpose): a
# plane, a box top, a scaled mesh quad and a scaled sphere all touching
# y = 0, and two identical spheres.  Nearly equal hits must be settled the
# same way through the BVH, by brute force and by 16-ray packets.
cat >"$T/ties.json" <<'JSON'
{"camera": {"position": [0.2, 3, 6], "look_at": [0, 0, 0], "fov_x": 60},
 "lights": [{"type": "point", "position": [3, 6, 4]}],
 "objects": [
  {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "material": {"color": [0.8, 0.2, 0.2]}},
  {"type": "box", "center": [0.5, -0.5, 0], "size": [2, 1, 2], "material": {"color": [0.2, 0.8, 0.2]}},
  {"type": "mesh", "vertices": [-1,0,-1, 1,0,-1, 1,0,1, -1,0,1], "indices": [0,2,1, 0,3,2],
   "transform": {"scale": 1.7, "translate": [-0.4, 0, 0.3]}, "material": {"color": [0.2, 0.2, 0.8]}},
  {"type": "sphere", "center": [0, 1, 0], "radius": 1, "transform": {"scale": [1.3, 0.7, 1.1], "translate": [1.5, -0.7, -1]},
   "material": {"color": [0.9, 0.9, 0.2]}},
  {"type": "sphere", "center": [-1.5, 0.6, 0], "radius": 0.6, "material": {"color": [0.2, 0.9, 0.9]}},
  {"type": "sphere", "center": [-1.5, 0.6, 0], "radius": 0.6, "material": {"color": [0.9, 0.2, 0.9]}}]}
JSON
"$RAYD_BUILD/tests/tools/bvhcheck" "$T/ties.json" 96 64
