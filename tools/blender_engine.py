"""autoact's Blender engine: renders the frames `autoact render --engine blender` describes with
Blender Cycles, through the PyPI `bpy` module (tools/setup-blender.sh makes its venv).

    python blender_engine.py MANIFEST.json

`autoact` embeds this file (include_str!) and writes it next to the manifest; it is not meant to
be run by hand, but it can be, on a manifest a failed run left behind.

The manifest (written by src/render/blender.rs) holds the scenes and the frames; its arrays
(meshes, textures, the skinned body of every frame) live in one little-endian binary file, each
named by {"offset": bytes, "count": elements}. The geometry is exactly the embedded renderer's:
- the body: the embedded renderer's mesh, skinned by autoact for each frame (so the silhouette
  matches the one the labels were measured on), per-vertex albedo (the clothes' pattern);
- props and backdrop: the embedded renderer's meshes, per-vertex albedo and normals;
- the ground: the floor and the surround as the embedded renderer's tiled textures (already
  weathered: wet, snowy), a water rectangle as a glossy surface;
- light: a sun along the scene's key direction and colour, the sky gradient (zenith, horizon)
  for camera rays and the scene's sky/ground ambient for light, fog as the embedded renderer's
  exponential blend towards the horizon colour, rain or snow as streaks and flakes around the
  camera, redrawn every frame;
- the camera: the capture's, per frame (optical frame z forward, x right, y down → Blender's
  camera looks down −z with y up), its focal length and principal point in pixels.

Per frame k it writes into the output folder `frame_{k:06}.png` (sRGB, 8-bit RGB) and, when
asked, `frame_{k:06}.depth` (float32 z-depth in metres along the optical axis, row-major from
the top-left, 0 where nothing is hit) and `frame_{k:06}.mask` (uint8, 1 where the character is
seen), both read from a multilayer EXR (Cycles' Z and object index passes), and prints
`autoact-frame k SECONDS` on stdout (seconds since the first frame started). Exit status 3: no
`bpy` in this Python.
"""

import json
import math
import os
import struct
import sys
import time
import warnings

warnings.filterwarnings("ignore", category=DeprecationWarning)  # bpy 5.x: `use_nodes` (still needed by 4.x)

try:
    import numpy as np
    import bpy
except ImportError as e:  # the caller maps status 3 to "run tools/setup-blender.sh"
    print(f"autoact-blender: {e}", file=sys.stderr)
    sys.exit(3)

PERSON_INDEX = 1


def array(data, spec, dtype, columns=1):
    a = np.frombuffer(data, dtype=dtype, count=spec["count"], offset=spec["offset"])
    return a.reshape(-1, columns) if columns > 1 else a


# ---------------------------------------------------------------------------------------------
# Materials


def fogged(tree, surface_socket, env):
    """Blends the surface towards the horizon colour with the scene's fog, for camera rays only
    (the embedded renderer's `1 - exp(-fog * distance)`)."""
    nodes, links = tree.nodes, tree.links
    out = nodes.new("ShaderNodeOutputMaterial")
    fog = env["fog_per_m"]
    if fog <= 0.0:
        links.new(surface_socket, out.inputs["Surface"])
        return
    cam = nodes.new("ShaderNodeCameraData")
    scaled = nodes.new("ShaderNodeMath")
    scaled.operation = "MULTIPLY"
    scaled.inputs[1].default_value = -fog
    links.new(cam.outputs["View Distance"], scaled.inputs[0])
    keep = nodes.new("ShaderNodeMath")
    keep.operation = "EXPONENT"
    links.new(scaled.outputs[0], keep.inputs[0])
    amount = nodes.new("ShaderNodeMath")
    amount.operation = "SUBTRACT"
    amount.inputs[0].default_value = 1.0
    links.new(keep.outputs[0], amount.inputs[1])
    path = nodes.new("ShaderNodeLightPath")
    only_camera = nodes.new("ShaderNodeMath")
    only_camera.operation = "MULTIPLY"
    links.new(amount.outputs[0], only_camera.inputs[0])
    links.new(path.outputs["Is Camera Ray"], only_camera.inputs[1])
    haze = nodes.new("ShaderNodeEmission")
    haze.inputs["Color"].default_value = (*env["horizon_rgb"], 1.0)
    mix = nodes.new("ShaderNodeMixShader")
    links.new(only_camera.outputs[0], mix.inputs["Fac"])
    links.new(surface_socket, mix.inputs[1])
    links.new(haze.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], out.inputs["Surface"])


def new_material(name):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    material.node_tree.nodes.clear()
    return material


def principled(tree, roughness, specular=0.3):
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = roughness
    for name in ("Specular IOR Level", "Specular"):
        if name in bsdf.inputs:
            bsdf.inputs[name].default_value = specular
            break
    return bsdf


def vertex_colour_material(name, env, roughness):
    material = new_material(name)
    tree = material.node_tree
    attribute = tree.nodes.new("ShaderNodeAttribute")
    attribute.attribute_name = "albedo"
    bsdf = principled(tree, roughness)
    tree.links.new(attribute.outputs["Color"], bsdf.inputs["Base Color"])
    fogged(tree, bsdf.outputs[0], env)
    return material


def texture_material(name, texture, data, env, roughness):
    size = texture["size"]
    texels = array(data, texture["texels"], "<f4", 3)
    rgba = np.ones((size * size, 4), dtype=np.float32)
    rgba[:, :3] = texels
    image = bpy.data.images.new(name, size, size, float_buffer=True)
    image.pixels.foreach_set(rgba.ravel())  # row 0 is the bottom: texel row v is world y
    material = new_material(name)
    tree = material.node_tree
    coords = tree.nodes.new("ShaderNodeTexCoord")
    scale = tree.nodes.new("ShaderNodeVectorMath")
    scale.operation = "SCALE"
    scale.inputs["Scale"].default_value = 1.0 / texture["tile_m"]
    tree.links.new(coords.outputs["Object"], scale.inputs[0])
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.interpolation = "Closest"
    tex.extension = "REPEAT"
    tree.links.new(scale.outputs[0], tex.inputs["Vector"])
    bsdf = principled(tree, roughness)
    tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    fogged(tree, bsdf.outputs[0], env)
    return material


def flat_material(name, rgb, env, roughness, specular=0.5):
    material = new_material(name)
    tree = material.node_tree
    bsdf = principled(tree, roughness, specular)
    bsdf.inputs["Base Color"].default_value = (*rgb, 1.0)
    fogged(tree, bsdf.outputs[0], env)
    return material


# ---------------------------------------------------------------------------------------------
# Meshes


def set_loop_totals(mesh, polygons, corners):
    """Blender before 4.x needs each polygon's corner count; later ones derive it (read-only)."""
    prop = mesh.polygons.bl_rna.properties.get("loop_total")
    if prop is not None and not prop.is_readonly:
        mesh.polygons.foreach_set("loop_total", np.full(polygons, corners, dtype=np.int32))


def mesh_object(name, collection, positions, indices, albedo=None, normals=None):
    mesh = bpy.data.meshes.new(name)
    faces = indices.reshape(-1, 3)
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.astype(np.float32).ravel())
    mesh.loops.add(len(faces) * 3)
    mesh.loops.foreach_set("vertex_index", faces.astype(np.int32).ravel())
    mesh.polygons.add(len(faces))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(faces), 3, dtype=np.int32))
    set_loop_totals(mesh, len(faces), 3)
    mesh.update(calc_edges=True)
    mesh.validate()
    if albedo is not None:
        attribute = mesh.color_attributes.new("albedo", "FLOAT_COLOR", "POINT")
        rgba = np.ones((len(positions), 4), dtype=np.float32)
        rgba[:, :3] = albedo
        attribute.data.foreach_set("color", rgba.ravel())
    if hasattr(mesh, "shade_smooth"):
        mesh.shade_smooth()
    else:
        mesh.polygons.foreach_set("use_smooth", [True] * len(mesh.polygons))
    if normals is not None and hasattr(mesh, "normals_split_custom_set_from_vertices"):
        mesh.normals_split_custom_set_from_vertices([tuple(n) for n in normals])
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    return obj


def quad(name, collection, x0, y0, x1, y1, z, material):
    positions = np.array([(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)], dtype=np.float32)
    obj = mesh_object(name, collection, positions, np.array([0, 1, 2, 0, 2, 3], dtype=np.uint32))
    obj.data.materials.append(material)
    return obj


def world_mesh(name, collection, spec, data, material):
    if spec["indices"]["count"] == 0:
        return None
    obj = mesh_object(
        name,
        collection,
        array(data, spec["positions"], "<f4", 3),
        array(data, spec["indices"], "<u4"),
        albedo=array(data, spec["albedo"], "<f4", 3),
        normals=array(data, spec["normals"], "<f4", 3),
    )
    obj.data.materials.append(material)
    return obj


# ---------------------------------------------------------------------------------------------
# Light and sky


def sky_world(name, env):
    """Camera rays see the embedded renderer's sky gradient (horizon → zenith by the square root
    of the ray's height); every other ray is lit by its ambient (ground ambient below, sky
    ambient above)."""
    world = bpy.data.worlds.new(name)
    world.use_nodes = True
    tree = world.node_tree
    nodes, links = tree.nodes, tree.links
    nodes.clear()
    coords = nodes.new("ShaderNodeTexCoord")
    xyz = nodes.new("ShaderNodeSeparateXYZ")
    links.new(coords.outputs["Generated"], xyz.inputs[0])
    up = nodes.new("ShaderNodeMath")
    up.operation = "MAXIMUM"
    up.inputs[1].default_value = 0.0
    links.new(xyz.outputs["Z"], up.inputs[0])
    root = nodes.new("ShaderNodeMath")
    root.operation = "SQRT"
    links.new(up.outputs[0], root.inputs[0])

    def mix_colour(fac, a, b):
        mix = nodes.new("ShaderNodeMix")
        mix.data_type = "RGBA"
        links.new(fac, mix.inputs["Factor"])
        mix.inputs[6].default_value = (*a, 1.0)  # A (colour)
        mix.inputs[7].default_value = (*b, 1.0)  # B (colour)
        return mix.outputs[2]

    sky = mix_colour(root.outputs[0], env["horizon_rgb"], env["zenith_rgb"])
    half = nodes.new("ShaderNodeMapRange")
    half.inputs["From Min"].default_value = -1.0
    links.new(xyz.outputs["Z"], half.inputs["Value"])
    ambient = mix_colour(half.outputs[0], env["ground_ambient_rgb"], env["sky_ambient_rgb"])
    path = nodes.new("ShaderNodeLightPath")
    choose = nodes.new("ShaderNodeMix")
    choose.data_type = "RGBA"
    links.new(path.outputs["Is Camera Ray"], choose.inputs["Factor"])
    links.new(ambient, choose.inputs[6])
    links.new(sky, choose.inputs[7])
    background = nodes.new("ShaderNodeBackground")
    links.new(choose.outputs[2], background.inputs["Color"])
    out = nodes.new("ShaderNodeOutputWorld")
    links.new(background.outputs[0], out.inputs["Surface"])
    return world


def sun(name, collection, env):
    from mathutils import Vector

    rgb = env["key_rgb"]
    strength = max(max(rgb), 0.0)
    data = bpy.data.lights.new(name, type="SUN")
    data.energy = strength  # irradiance: a white surface facing it shows `strength`
    data.color = [c / strength for c in rgb] if strength > 1e-6 else [1.0, 1.0, 1.0]
    data.angle = math.radians(0.53)
    if hasattr(data, "use_shadow"):
        data.use_shadow = bool(env["key_shadows"])
    obj = bpy.data.objects.new(name, data)
    collection.objects.link(obj)
    # A sun shines down its local −z: point +z at the light.
    obj.rotation_euler = Vector(env["key_dir"]).to_track_quat("Z", "Y").to_euler()
    return obj


# ---------------------------------------------------------------------------------------------
# Rain and snow


def precipitation_object(name, collection, env):
    kind, rate = env["precipitation"]
    if kind == "none" or rate <= 0.0 or env["indoor"]:
        return None
    rain = kind == "rain"
    count = int(min(max(rate * (120.0 if rain else 900.0), 300.0 if rain else 400.0), 3000.0))
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(4 * count)
    mesh.loops.add(4 * count)
    mesh.loops.foreach_set("vertex_index", np.arange(4 * count, dtype=np.int32))
    mesh.polygons.add(count)
    mesh.polygons.foreach_set("loop_start", np.arange(0, 4 * count, 4, dtype=np.int32))
    set_loop_totals(mesh, count, 4)
    mesh.update(calc_edges=True)
    material = new_material(name)
    tree = material.node_tree
    glow = tree.nodes.new("ShaderNodeEmission")
    shade = 0.2 + min(env["sky_ambient_rgb"][1] + 0.3 * env["key_rgb"][1], 0.8)
    colour = [0.6 * shade, 0.62 * shade, 0.66 * shade] if rain else [0.9 * shade] * 3
    glow.inputs["Color"].default_value = (*colour, 1.0)
    clear = tree.nodes.new("ShaderNodeBsdfTransparent")
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.35 if rain else 0.8
    tree.links.new(clear.outputs[0], mix.inputs[1])
    tree.links.new(glow.outputs[0], mix.inputs[2])
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    for flag in ("visible_shadow", "visible_diffuse", "visible_glossy", "visible_transmission"):
        if hasattr(obj, flag):
            setattr(obj, flag, False)
    collection.objects.link(obj)
    obj["autoact_rain"] = rain
    obj["autoact_count"] = count
    return obj


def place_precipitation(obj, env, seed, k, time_s, eye, forward, right, up):
    """Streaks (rain, 0.5 m long, slanted by the wind) or flakes (2 cm) in a 16 m box in front
    of the camera (from 2 m on), drawn anew for frame k."""
    rain, count = bool(obj["autoact_rain"]), int(obj["autoact_count"])
    rng = np.random.default_rng([seed & 0xFFFFFFFF, k])
    box = 16.0
    # 2–16 m ahead (nearer, a streak would fill the frame), ±8 m across and up.
    ahead = 2.0 + rng.random((count, 1)) * (box - 2.0)
    across = (rng.random((count, 2)) - 0.5) * box
    p = eye + forward * ahead + right * across[:, :1] + up * across[:, 1:]
    wind = min(env["wind_m_per_s"], 20.0)
    if rain:
        fall = np.array([wind * 0.05, 0.0, -0.5])
        width = right * 0.012
        a, b = p, p + fall
        quads = np.stack([a - width, a + width, b + width, b - width], axis=1)
    else:
        size = 0.02
        r, u = right * size, up * size
        quads = np.stack([p - r - u, p + r - u, p + r + u, p - r + u], axis=1)
    obj.data.vertices.foreach_set("co", quads.astype(np.float32).ravel())
    obj.data.update()


# ---------------------------------------------------------------------------------------------
# Scenes


def build_scene(i, spec, data):
    env = spec["environment"]
    collection = bpy.data.collections.new(f"scene_{i}")
    bpy.context.scene.collection.children.link(collection)
    body_positions = np.zeros((spec["body"]["vertices"], 3), dtype=np.float32)
    body = mesh_object(
        f"body_{i}",
        collection,
        body_positions,
        array(data, spec["body"]["indices"], "<u4"),
        albedo=array(data, spec["body"]["albedo"], "<f4", 3),
    )
    body.data.materials.append(vertex_colour_material(f"body_{i}", env, 0.75))
    body.pass_index = PERSON_INDEX
    world_mesh(f"props_{i}", collection, spec["props"], data, vertex_colour_material(f"props_{i}", env, 0.7))
    backdrop_material = vertex_colour_material(f"backdrop_{i}", env, 0.9)
    backdrop = world_mesh(f"backdrop_{i}", collection, spec["backdrop"], data, backdrop_material)
    if backdrop is not None and hasattr(backdrop, "visible_shadow"):
        backdrop.visible_shadow = False  # as in the embedded renderer: the far backdrop casts none
    ground = spec["ground"]
    wet_roughness = 0.9 - 0.6 * env["wetness"]
    hx, hy = ground["floor_half_m"]
    far = 2000.0
    quad(f"surround_{i}", collection, -far, -far, far, far, -0.004,
         texture_material(f"surround_{i}", ground["surround"], data, env, wet_roughness))
    quad(f"floor_{i}", collection, -hx, -hy, hx, hy, 0.0,
         texture_material(f"floor_{i}", ground["floor"], data, env, wet_roughness))
    if ground["water"] is not None:
        x0, y0, x1, y1 = ground["water"]
        quad(f"water_{i}", collection, x0, y0, x1, y1, 0.004,
             flat_material(f"water_{i}", ground["water_rgb"], env, 0.05, 1.0))
    sun(f"sun_{i}", collection, env)
    rain = precipitation_object(f"precipitation_{i}", collection, env)
    return {"collection": collection, "body": body, "world": sky_world(f"sky_{i}", env),
            "rain": rain, "env": env, "seed": spec["seed"]}


def show_only(view_layer, scenes, active):
    for j, s in enumerate(scenes):
        view_layer.layer_collection.children[s["collection"].name].exclude = j != active


# ---------------------------------------------------------------------------------------------
# Render settings, device


def choose_device(scene):
    """The first GPU backend Cycles finds (OptiX, CUDA, HIP, oneAPI, Metal), else the CPU;
    AUTOACT_BLENDER_DEVICE=cpu forces the CPU."""
    scene.cycles.device = "CPU"
    if os.environ.get("AUTOACT_BLENDER_DEVICE", "auto").lower() == "cpu":
        return "CPU (forced by AUTOACT_BLENDER_DEVICE)"
    try:
        prefs = bpy.context.preferences.addons["cycles"].preferences
    except (KeyError, AttributeError):
        return "CPU"
    for kind in ("OPTIX", "CUDA", "HIP", "ONEAPI", "METAL"):
        try:
            prefs.compute_device_type = kind
        except (TypeError, ValueError):
            continue
        try:
            if hasattr(prefs, "refresh_devices"):
                prefs.refresh_devices()
            else:
                prefs.get_devices()
        except Exception:  # a backend without its driver
            continue
        gpus = [d for d in prefs.devices if d.type == kind]
        if gpus:
            for d in prefs.devices:
                d.use = d.type == kind
            scene.cycles.device = "GPU"
            return f"GPU {kind} ({', '.join(d.name for d in gpus)})"
    try:
        prefs.compute_device_type = "NONE"
    except (TypeError, ValueError):
        pass
    return "CPU"


def set_up_render(scene, m):
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = m["width"], m["height"], 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    if m.get("threads"):
        r.threads_mode, r.threads = "FIXED", int(m["threads"])
    if hasattr(r, "use_persistent_data"):
        r.use_persistent_data = True
    r.film_transparent = False
    r.dither_intensity = 0.0
    scene.cycles.samples = int(m["samples"])
    scene.cycles.use_denoising = bool(m["denoise"])
    scene.cycles.max_bounces = 4
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.display_settings.display_device = "sRGB"
    layer = scene.view_layers[0]
    layer.use_pass_z = bool(m["depth"] or m["mask"])
    layer.use_pass_object_index = bool(m["mask"])
    if hasattr(layer, "pass_alpha_threshold"):
        layer.pass_alpha_threshold = 0.9  # rain and snow (alpha ≤ 0.8) stay out of depth and mask
    return choose_device(scene)


def camera_object(scene):
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "HORIZONTAL"
    data.sensor_width = 36.0
    data.clip_start = 0.05
    data.clip_end = 5000.0
    cam = bpy.data.objects.new("camera", data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return cam


def place_camera(cam, frame, width, height):
    """The optical frame (z forward, x right, y down) → Blender's camera (−z forward, y up): a
    half turn about x. Focal length and principal point in pixels → lens and shift."""
    from mathutils import Matrix

    m = Matrix([frame["world_from_optical"][4 * r : 4 * r + 4] for r in range(4)])
    cam.matrix_world = m @ Matrix.Rotation(math.pi, 4, "X")
    data = cam.data
    data.lens = frame["fx"] * data.sensor_width / width
    data.shift_x = (width / 2.0 - frame["cx"]) / width
    data.shift_y = (frame["cy"] - height / 2.0) / width
    return np.array(m.col[3][:3]), np.array(m.col[2][:3]), np.array(m.col[0][:3]), -np.array(m.col[1][:3])


# ---------------------------------------------------------------------------------------------
# Passes: a multilayer EXR, uncompressed, read here


def read_exr(path):
    """Channels of an uncompressed scanline OpenEXR, single- or multi-part (Blender 5 writes a
    multilayer file as one part per pass), as float32 arrays (row 0 on top)."""
    with open(path, "rb") as f:
        b = f.read()
    magic, version = struct.unpack_from("<II", b, 0)
    multipart = bool(version & 0x1000)
    if magic != 20000630 or version & 0xA00:
        raise SystemExit(f"{path}: not a scanline OpenEXR (version {version:#x})")
    pos, parts = 8, []
    while True:  # one header per part; a multi-part file ends the list with an empty header
        header = {"channels": [], "name": ""}
        while True:
            end = b.index(b"\0", pos)
            name = b[pos:end].decode()
            pos = end + 1
            if not name:
                break
            end = b.index(b"\0", pos)
            pos = end + 1
            (size,) = struct.unpack_from("<i", b, pos)
            pos += 4
            value = b[pos : pos + size]
            pos += size
            if name == "channels":
                p = 0
                while value[p] != 0:
                    e = value.index(b"\0", p)
                    kind = struct.unpack_from("<i", value, e + 1)[0]
                    header["channels"].append((value[p:e].decode(), kind))
                    p = e + 1 + 16
            elif name == "dataWindow":
                header["window"] = struct.unpack("<4i", value)
            elif name == "compression":
                header["compression"] = value[0]
            elif name == "name":
                header["name"] = value.rstrip(b"\0").decode()
            elif name == "chunkCount":
                header["chunks"] = struct.unpack("<i", value)[0]
        if header["channels"] or not multipart:
            parts.append(header)
        if not multipart or not header["channels"]:
            break
    dtypes = {0: "<u4", 1: "<f2", 2: "<f4"}
    out = {}
    for part in parts:
        if part.get("compression") != 0:
            raise SystemExit(f"{path}: compressed EXR ({part.get('compression')}); expected none")
        x0, y0, x1, y1 = part["window"]
        part["w"], part["h"] = x1 - x0 + 1, y1 - y0 + 1
        part["offsets"] = np.frombuffer(b, "<u8", part.get("chunks", part["h"]), pos)
        pos += 8 * len(part["offsets"])
    for i, part in enumerate(parts):
        w, h, y0 = part["w"], part["h"], part["window"][1]
        planes = {c: np.empty((h, w), dtype=np.float32) for c, _ in part["channels"]}
        for offset in part["offsets"]:
            p = int(offset) + (4 if multipart else 0)  # a multi-part chunk starts with its part number
            y, _ = struct.unpack_from("<ii", b, p)
            p += 8
            for c, t in part["channels"]:
                dt = np.dtype(dtypes[t])
                planes[c][y - y0] = np.frombuffer(b, dt, w, p)
                p += w * dt.itemsize
        out.update(planes)  # Blender's channel names already carry the layer and pass
    return out


def channel(channels, suffixes, path):
    for name, values in channels.items():
        if name.endswith(suffixes):
            return values
    raise SystemExit(f"{path}: no channel *{suffixes} among {sorted(channels)}")


def write_passes(scene, image, exr_path, stem, m):
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):
        settings.media_type = "MULTI_LAYER_IMAGE"  # Blender 5.x
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.color_depth = "32"
    settings.exr_codec = "NONE"
    image.save_render(exr_path, scene=scene)
    channels = read_exr(exr_path)
    os.remove(exr_path)
    if m["depth"]:
        z = channel(channels, ("Depth.Z",), exr_path)
        z = np.where(np.isfinite(z) & (z > 0.0) & (z < 1e9), z, 0.0).astype("<f4")
        z.tofile(stem + ".depth")
    if m["mask"]:
        index = channel(channels, ("IndexOB.X", "Object Index.X"), exr_path)
        (np.rint(index) == PERSON_INDEX).astype(np.uint8).tofile(stem + ".mask")


# ---------------------------------------------------------------------------------------------


def main():
    begun = time.time()
    manifest_path = sys.argv[-1]
    with open(manifest_path) as f:
        m = json.load(f)
    with open(m["data"], "rb") as f:
        data = f.read()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    device = set_up_render(scene, m)
    print(f"autoact-blender: Blender {bpy.app.version_string}, Cycles on {device}", flush=True)
    scenes = [build_scene(i, s, data) for i, s in enumerate(m["scenes"])]
    cam = camera_object(scene)
    view_layer = scene.view_layers[0]
    out = m["out_dir"]
    width, height = m["width"], m["height"]
    active = None
    started = time.time()
    for k, frame in enumerate(m["frames"]):
        s = scenes[frame["scene"]]
        if frame["scene"] != active:
            show_only(view_layer, scenes, frame["scene"])
            scene.world = s["world"]
            active = frame["scene"]
        body = array(data, frame["body"], "<f4", 3)
        s["body"].data.vertices.foreach_set("co", body.ravel())
        s["body"].data.update()
        eye, forward, right, up = place_camera(cam, frame, width, height)
        if s["rain"] is not None:
            place_precipitation(s["rain"], s["env"], s["seed"], k, frame["time_s"], eye, forward, right, up)
        bpy.ops.render.render()
        image = bpy.data.images["Render Result"]
        stem = os.path.join(out, f"frame_{k:06d}")
        settings = scene.render.image_settings
        if hasattr(settings, "media_type"):
            settings.media_type = "IMAGE"  # Blender 5.x
        settings.file_format = "PNG"
        settings.color_mode = "RGB"
        settings.color_depth = "8"
        image.save_render(stem + ".png", scene=scene)
        if m["depth"] or m["mask"]:
            write_passes(scene, image, stem + ".exr", stem, m)
        print(f"autoact-frame {k} {time.time() - started:.2f}", flush=True)
    n = len(m["frames"])
    took = time.time() - started
    print(f"autoact-blender: {n} frames in {took:.1f} s ({took / max(n, 1):.2f} s/frame) after "
          f"{started - begun:.1f} s of start-up and scene set-up", flush=True)


if __name__ == "__main__":
    main()
