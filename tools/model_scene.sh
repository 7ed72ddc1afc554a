#!/bin/sh
# model_scene.sh AZIMUTH WIDTH HEIGHT SAMPLES -- the README's model picture
# as a scene on stdout: Wuson.ply (assimp-testmodels) in terracotta on a
# grey floor under studio.hdr, both looked up beside the scene file, framed
# whole from AZIMUTH degrees.  tools/readme_images.sh draws the picture and
# the turntable with it; bench/denoise.sh measures the denoiser on it.
cat <<EOF
{
 "camera": {"frame": "all", "azimuth": $1, "elevation": 15, "fov_y": 30},
 "render": {"width": $2, "height": $3, "samples": $4, "max_depth": 4, "integrator": "path",
            "environment": {"file": "studio.hdr"}},
 "materials": {
  "terracotta": {"color": [0.6, 0.29, 0.15], "metallic": 0.3, "roughness": 0.35},
  "floor": {"color": [0.5, 0.5, 0.52]}
 },
 "objects": [
  {"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "material": "floor"},
  {"type": "mesh", "source": {"file": "Wuson.ply"}, "smooth": true, "material": "terracotta"}
 ]
}
EOF
