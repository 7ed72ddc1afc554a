# cycles_pt.py -- a rayd scene rebuilt in Blender and rendered by Cycles,
# for bench/pt.py (`make bench-pt`).
#
#   blender -b -noaudio --factory-startup -P bench/peers/cycles_pt.py -- \
#       SCENE.json OUT.exr SAMPLES SEED THREADS
#
# The one description of each benchmark scene is rayd's JSON (pt.py writes
# it); this reads the subset pt.py uses and builds the same thing in
# Cycles, number for number:
#   camera    position, look_at, up +y and fov_x: Blender's camera with the
#             sensor fitted horizontally and that angle; rayd's y-up
#             coordinates become Blender's z-up ones, (x, y, z) -> (x, -z, y)
#             (a rotation, so nothing is mirrored)
#   objects   quads (two triangles), boxes (six quads, rotate then
#             translate as rayd's transform does), spheres (smooth UV
#             spheres of 256 x 128 segments: Cycles has no analytic sphere
#             that refracts) and PLY meshes (flat, as "smooth": false)
#   materials diffuse -> Diffuse BSDF (Lambert) of colour x diffuse;
#             transparency 1 -> sharp Glass BSDF of that ior; metallic 1 ->
#             Principled BSDF, GGX, metallic 1, that roughness (both: alpha
#             = roughness^2, F0 = colour); emission -> an Emission shader
#             of strength 1 and colour = rayd's radiance (Cycles' mesh
#             lights, like rayd's quads, shine from both faces)
#   render    max_depth - 1 -> max bounces (every kind), no clamping, glossy
#             filter off, caustics on, box pixel filter one pixel wide (as
#             rayd's samples spread over the pixel), no adaptive sampling,
#             no denoising, 'Standard' view transform, linear float EXR
#   world     black, or the equirectangular environment file at its
#             intensity, read nearest-texel and turned so that rayd's
#             layout (centre towards -z, left and right edges meeting at +z)
#             is Cycles' too
# Prints "PT_RENDER_S seconds": the render alone (scene sync, BVH build,
# sampling and the EXR write), as Blender's own "Time:" line counts it.
import json
import math
import os
import sys
import time

import bpy
import mathutils


def to_b(p):
    return (p[0], -p[2], p[1])


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def add(a, b):
    return [a[i] + b[i] for i in range(3)]


def material(name, m):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    col = list(m.get("color", [1, 1, 1]))
    if m.get("transparency", 0) > 0:
        bsdf = nt.nodes.new("ShaderNodeBsdfGlass")
        bsdf.distribution = "SHARP"
        bsdf.inputs["IOR"].default_value = m.get("ior", 1.5)
        bsdf.inputs["Color"].default_value = col + [1]
    elif m.get("metallic", 0) > 0:
        bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
        bsdf.distribution = "GGX"
        bsdf.inputs["Base Color"].default_value = col + [1]
        bsdf.inputs["Metallic"].default_value = m["metallic"]
        bsdf.inputs["Roughness"].default_value = m.get("roughness", 0)
    else:
        bsdf = nt.nodes.new("ShaderNodeBsdfDiffuse")
        d = m.get("diffuse", 1)
        bsdf.inputs["Color"].default_value = [c * d for c in col] + [1]
        bsdf.inputs["Roughness"].default_value = 0
    shader = bsdf.outputs[0]
    e = m.get("emission", [0, 0, 0])
    if max(e) > 0:
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = list(e) + [1]
        em.inputs["Strength"].default_value = 1
        if max(col) > 0:
            addn = nt.nodes.new("ShaderNodeAddShader")
            nt.links.new(shader, addn.inputs[0])
            nt.links.new(em.outputs[0], addn.inputs[1])
            shader = addn.outputs[0]
        else:
            shader = em.outputs[0]
    nt.links.new(shader, out.inputs["Surface"])
    return mat


def mesh_object(name, verts, faces, mat, smooth=False):
    me = bpy.data.meshes.new(name)
    me.from_pydata([to_b(v) for v in verts], [], faces)
    for p in me.polygons:
        p.use_smooth = smooth
    me.materials.append(mat)
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def quad(o):
    c, e1, e2 = o["corner"], o["edge1"], o["edge2"]
    return [c, add(c, e1), add(add(c, e1), e2), add(c, e2)], [(0, 1, 2, 3)]


def box(o):
    c, s = o["center"], o["size"]
    t = o.get("transform", {})
    ry = math.radians(t.get("rotate", [0, 0, 0])[1])
    tr = t.get("translate", [0, 0, 0])
    verts = []
    for i in range(8):
        p = [c[k] + s[k] / 2 * (1 if (i >> k) & 1 else -1) for k in range(3)]
        x, z = p[0], p[2]  # rotate about +y (right-handed), then translate
        p = [x * math.cos(ry) + z * math.sin(ry), p[1], -x * math.sin(ry) + z * math.cos(ry)]
        verts.append(add(p, tr))
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return verts, faces


def sphere(name, o, mat):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=256, ring_count=128, radius=o["radius"],
                                         location=to_b(o["center"]))
    ob = bpy.context.active_object
    ob.name = name
    for p in ob.data.polygons:
        p.use_smooth = True
    ob.data.materials.append(mat)


def ply(name, path, mat):
    bpy.ops.import_mesh.ply(filepath=path)
    ob = bpy.context.selected_objects[0]
    ob.name = name
    ob.rotation_euler = (math.pi / 2, 0, 0)  # (x, y, z) -> (x, -z, y), as to_b
    for p in ob.data.polygons:
        p.use_smooth = False
    ob.data.materials.clear()
    ob.data.materials.append(mat)


def camera(cam, w):
    pos, look = cam["position"], cam["look_at"]
    f = mathutils.Vector(to_b(sub(look, pos))).normalized()
    up = mathutils.Vector(to_b(cam.get("up", [0, 1, 0])))
    r = f.cross(up).normalized()
    u = r.cross(f)
    m = mathutils.Matrix((r, u, -f)).transposed()  # columns: camera x, y, z
    data = bpy.data.cameras.new("cam")
    data.sensor_fit = "HORIZONTAL"
    data.angle = math.radians(cam["fov_x"])
    data.clip_start = 1e-4
    data.clip_end = 1e6
    ob = bpy.data.objects.new("cam", data)
    ob.matrix_world = mathutils.Matrix.Translation(to_b(pos)) @ m.to_4x4()
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.scene.camera = ob


def world(scene_dir, rs):
    wo = bpy.data.worlds.new("world")
    bpy.context.scene.world = wo
    wo.use_nodes = True
    nt = wo.node_tree
    bg = nt.nodes["Background"]
    env = rs.get("environment")
    if not env:
        bg.inputs["Color"].default_value = list(rs.get("background", [0, 0, 0])) + [1]
        bg.inputs["Strength"].default_value = 1
        return
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(os.path.join(scene_dir, env["file"]))
    tex.interpolation = "Closest"
    # Blender's u is rayd's + 1/4 for the same direction: turn the lookup
    # 90 degrees about z (rayd's +y) to line the two layouts up.
    coord = nt.nodes.new("ShaderNodeTexCoord")
    mapn = nt.nodes.new("ShaderNodeMapping")
    mapn.vector_type = "VECTOR"
    mapn.inputs["Rotation"].default_value = (0, 0, math.radians(90))
    nt.links.new(coord.outputs["Generated"], mapn.inputs["Vector"])
    nt.links.new(mapn.outputs["Vector"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = env.get("intensity", 1)


def settings(rs, samples, seed, threads, out):
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = samples
    cy.seed = seed
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    # Cycles samples the lights at the vertex whose bounce count equals
    # the limit too (its "Direct Light" preset is diffuse_bounces 0): a
    # limit of n allows n + 1 reflections, rayd's max_depth n allows n.
    n = max(0, rs.get("max_depth", 5) - 1)
    cy.max_bounces = n
    cy.diffuse_bounces = cy.glossy_bounces = cy.transmission_bounces = n
    cy.transparent_max_bounces = n
    cy.sample_clamp_direct = cy.sample_clamp_indirect = 0
    cy.blur_glossy = 0
    cy.caustics_reflective = cy.caustics_refractive = True
    cy.light_sampling_threshold = 0
    cy.filter_type = "BOX"
    cy.filter_width = 1.0
    sc.render.film_transparent = False
    sc.render.resolution_x = rs["width"]
    sc.render.resolution_y = rs["height"]
    sc.render.resolution_percentage = 100
    sc.render.threads_mode = "FIXED"
    sc.render.threads = threads
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0
    sc.view_settings.gamma = 1
    im = sc.render.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGB"
    im.color_depth = "32"
    im.exr_codec = "ZIP"
    sc.render.filepath = out


def main():
    args = sys.argv[sys.argv.index("--") + 1:]
    path, out, samples, seed, threads = args[0], args[1], int(args[2]), int(args[3]), int(args[4])
    with open(path) as f:
        s = json.load(f)
    scene_dir = os.path.dirname(os.path.abspath(path))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mats = {k: material(k, v) for k, v in s.get("materials", {}).items()}
    for i, o in enumerate(s["objects"]):
        m = o["material"]
        mat = mats[m] if isinstance(m, str) else material("m%d" % i, m)
        name = "o%d" % i
        if o["type"] == "quad":
            mesh_object(name, *quad(o), mat)
        elif o["type"] == "box":
            mesh_object(name, *box(o), mat)
        elif o["type"] == "sphere":
            sphere(name, o, mat)
        elif o["type"] == "mesh":
            ply(name, os.path.join(scene_dir, o["source"]["file"]), mat)
        else:
            raise SystemExit("cycles_pt: object type %s not supported" % o["type"])
    camera(s["camera"], s["render"]["width"])
    world(scene_dir, s["render"])
    settings(s["render"], samples, seed, threads, os.path.abspath(out))
    t = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    print("PT_RENDER_S %.4f" % (time.perf_counter() - t), flush=True)


main()
