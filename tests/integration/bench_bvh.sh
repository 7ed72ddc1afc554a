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
