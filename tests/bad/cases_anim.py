"""cases_anim.py -- the bad-scene corpus's animation cases (make_scenes.py
reads them): the /animation block and keyframes (core/load/scene_json_anim.c).
"""


def add(case):
    """Adds every animation case through make_scenes.py's case()."""
    A = '"animation": {"end": 10}, '
    case("anim-keyframes-without-animation.json",
         '{"camera": {"keyframes": [{"frame": 0, "position": [0, 0, 1]}]}}\n',
         "error: /camera/keyframes: needs /animation (the scene's frame range)")
    case("anim-unknown-key.json", '{"animation": {"end": 5, "speed": 2}}\n',
         "error: /animation/speed: unknown key (allowed here: start, end, fps)")
    case("anim-end-missing.json", '{"animation": {"start": 0}}\n',
         "error: /animation/end: is required (the last frame)")
    case("anim-end-before-start.json", '{"animation": {"start": 5, "end": 2}}\n',
         "error: /animation/end: must be >= /animation/start (5)")
    case("anim-fps-zero.json", '{"animation": {"end": 5, "fps": 0}}\n',
         "error: /animation/fps: must be >= 0.001")
    # a rate ffmpeg cannot take: the video would fail after every frame is made
    case("anim-fps-tiny.json", '{"animation": {"end": 5, "fps": 1e-6}}\n',
         "error: /animation/fps: must be >= 0.001")
    case("anim-end-fraction.json", '{"animation": {"end": 2.5}}\n',
         "error: /animation/end: must be an integer")
    case("anim-end-over.json", '{"animation": {"end": 1000001}}\n',
         "error: /animation/end: must be <= 1000000")
    case("keyframes-out-of-order.json",
         '{' + A + '"camera": {"keyframes": [{"frame": 0, "fov_x": 40}, {"frame": 5, "fov_x": 50}, {"frame": 3, "fov_x": 60}]}}\n',
         "error: /camera/keyframes/2/frame: 3 comes before keyframe 1's frame 5 (keyframes go in frame order)")
    case("keyframes-duplicate-frame.json",
         '{' + A + '"camera": {"keyframes": [{"frame": 5, "fov_x": 40}, {"frame": 5, "fov_x": 50}]}}\n',
         "error: /camera/keyframes/1/frame: 5 is the frame of keyframe 0 too (one keyframe a frame)")
    case("keyframes-outside-range.json",
         '{' + A + '"objects": [{"type": "sphere", "keyframes": [{"frame": 0, "translate": [0, 0, 0]}, {"frame": 12, "translate": [0, 1, 0]}]}]}\n',
         "error: /objects/0/keyframes/1/frame: 12 is outside the animation's frames 0-10")
    case("keyframes-unknown-key.json",
         '{' + A + '"camera": {"keyframes": [{"frame": 0, "radius": 1}]}}\n',
         "error: /camera/keyframes/0/radius: unknown key (allowed here: frame, position, look_at, up, fov_x, fov_y, focus_distance, aperture, azimuth, elevation)")
    case("keyframes-wrong-type.json",
         '{' + A + '"camera": {"keyframes": [{"frame": 0, "position": "up"}]}}\n',
         "error: /camera/keyframes/0/position: must be an array of 3 numbers")
    case("keyframes-frame-missing.json",
         '{' + A + '"lights": [{"type": "point", "keyframes": [{"position": [0, 1, 0]}]}]}\n',
         "error: /lights/0/keyframes/0/frame: is required (the keyframe's frame number)")
    case("keyframes-frame-string.json",
         '{' + A + '"lights": [{"type": "point", "keyframes": [{"frame": "0", "intensity": 1}]}]}\n',
         "error: /lights/0/keyframes/0/frame: must be a number, not a string")
    case("keyframes-not-array.json", '{' + A + '"camera": {"keyframes": {"frame": 0}}}\n',
         "error: /camera/keyframes: must be a non-empty array of keyframes")
    case("keyframes-empty.json", '{' + A + '"camera": {"keyframes": []}}\n',
         "error: /camera/keyframes: must be a non-empty array of keyframes")
    case("keyframes-only-frame.json", '{' + A + '"camera": {"keyframes": [{"frame": 0}]}}\n',
         "error: /camera/keyframes/0: has a frame and nothing to animate")
    case("interpolation-unknown.json",
         '{' + A + '"camera": {"interpolation": "cubic", "keyframes": [{"frame": 0, "fov_x": 40}]}}\n',
         'error: /camera/interpolation: unknown value "cubic" (supported: linear, smooth, step)')
    case("interpolation-without-keyframes.json",
         '{' + A + '"objects": [{"type": "sphere", "interpolation": "smooth"}]}\n',
         "error: /objects/0/interpolation: needs keyframes beside it")
    case("keyframes-and-still-value.json",
         '{' + A + '"camera": {"position": [0, 0, 5], "keyframes": [{"frame": 0, "position": [0, 0, 4]}]}}\n',
         "error: /camera/position: is animated by /camera/keyframes too: give it in one place")
    case("keyframes-point-light-direction.json",
         '{' + A + '"lights": [{"type": "point", "keyframes": [{"frame": 0, "direction": [0, -1, 0]}]}]}\n',
         "error: /lights/0/keyframes/0/direction: unknown key (allowed here: frame, position, color, intensity)")
    case("keyframes-light-color-negative.json",
         '{' + A + '"lights": [{"type": "point", "keyframes": [{"frame": 0, "color": [1, -1, 1]}]}]}\n',
         "error: /lights/0/keyframes/0/color/1: must be >= 0")
    case("keyframes-intensity-over.json",
         '{' + A + '"lights": [{"type": "spot", "keyframes": [{"frame": 0, "intensity": 2e6}]}]}\n',
         "error: /lights/0/keyframes/0/intensity: must be <= 1e+06")
    case("keyframes-scale-zero.json",
         '{' + A + '"objects": [{"type": "sphere", "keyframes": [{"frame": 0, "scale": [1, 0, 1]}]}]}\n',
         "error: /objects/0/keyframes/0/scale: must not be zero (or smaller than 1e-9) in any axis")
    case("keyframes-rotate-axis-zero.json",
         '{' + A + '"objects": [{"type": "box", "keyframes": [{"frame": 0, "rotate": {"axis": [0, 0, 0], "angle": 5}}]}]}\n',
         "error: /objects/0/keyframes/0/rotate/axis: must not be a zero-length vector")
    case("keyframes-group-member.json",
         '{' + A + '"groups": {"g": [{"type": "sphere", "keyframes": [{"frame": 0, "translate": 1}]}]}, "objects": [{"type": "instance", "group": "g"}]}\n',
         "error: /groups/g/0/keyframes/0/translate: must be an array of 3 numbers")
    case("keyframes-csg-operand.json",
         '{' + A + '"objects": [{"type": "csg", "op": "union", "operands": [{"type": "sphere"}, {"type": "box", "keyframes": [{"frame": 11, "scale": 2}]}]}]}\n',
         "error: /objects/0/operands/1/keyframes/0/frame: 11 is outside the animation's frames 0-10")
    case("keyframes-twice.json",
         '{' + A + '"objects": [{"type": "sphere", "keyframes": [{"frame": 0, "scale": 2}], "keyframes": [{"frame": 1, "scale": 2}]}]}\n',
         "error: /objects/0/keyframes: duplicate key")
    case("keyframes-up-parallel.json",
         '{' + A + '"camera": {"position": [0, 5, 0], "look_at": [0, 0, 0], "keyframes": [{"frame": 0, "up": [0, 1, 0]}]}}\n',
         "error: /camera/keyframes: at frame 0, up: must not be parallel to the view direction (look_at - position)")
    case("keyframes-with-frame-all.json",
         '{' + A + '"camera": {"frame": "all", "keyframes": [{"frame": 0, "position": [0, 1, 5]}]}, "objects": [{"type": "sphere"}]}\n',
         "error: /camera/keyframes: at frame 0, position: must not be given with /camera/frame (the view sets it)")
