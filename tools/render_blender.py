"""Render an `autoact export --format glb|gltf` file with Blender, headless.

Usage (either Blender's own Python or the PyPI `bpy` module, Python 3.13):

    blender -b --python tools/render_blender.py -- IN.glb OUT [options]
    python3.13 tools/render_blender.py IN.glb OUT [options]        # with `pip install bpy==5.2.3`
    "$(tools/setup-blender.sh | tail -n1)" tools/render_blender.py IN.glb OUT [options]   # its venv

(`autoact render CAPTURE --engine blender` renders a capture with Blender Cycles directly, with the
render bag and labels; this script is for a GLB from `autoact export`.)

OUT is a folder for PNG frames (`frame_0000.png`, ... : file k is timeline frame k) or, with
`--video`, an `.mp4` file (H.264). Options:

    --engine workbench|cycles|eevee   render engine (default workbench: fast on a CPU)
    --width W --height H              resolution in pixels (default 320 x 240)
    --fps F                           frame rate (default: the file's `extras.autoact.fps`, else 30)
    --frames N                        render only the first N frames (default: every frame)
    --samples S                       Cycles/Eevee samples (default 16)
    --threads T                       render threads (default: all cores)

The timeline is the export's: rendered frame k is the animation's frame k, at k / fps seconds
after the first frame, exactly like an `autoact render` capture, so `autoact trim` cuts it the
same way (the file's extras carry the clips' `start_frame`/`end_frame`).

Scene set-up:
- `scene.render.fps` is set BEFORE the import: Blender's glTF importer maps glTF seconds to
  frames at the scene's rate, so importing at the default 24 fps would stretch a 30 fps clip.
- Camera: the file's animated camera (capture bags), else a default camera 4 m in front of the
  character's first position, looking at its hips.
- Light and sky: from `scenes[0].extras.autoact.scenes[0].lighting` when the file has it (the key
  light's direction and colour and the sky colours the embedded renderer uses for the scene's
  time of day and weather), else a default afternoon sun and a pale blue sky. A ground plane at
  z = 0 catches the shadows.
- Axes: autoact exports Z-up metres under the node `autoact_world` turned to glTF's Y-up, and the
  importer turns it back, so Blender's world coordinates are autoact's (x east, y north, z up).

docs/blender-still.png is frame 15 of (bpy 5.2.3, Python 3.13, 2 CPU threads, about 12 s in all):

    autoact convert --spec examples/dataset.toml -o capture
    autoact export capture/demo_locomotion_walk_0001.capture.mcap --format glb -o glb
    python3.13 tools/render_blender.py glb/demo_locomotion_walk_0001_track0_v0.glb frames \
        --frames 30 --threads 2           # Workbench, 320 x 240

Blender 3.4 (Debian's `blender` package) needs numpy's removed `np.bool` in its glTF importer; the
shim below restores it.
"""

import argparse
import json
import math
import os
import struct
import sys

try:
    import numpy as _np

    if "bool" not in _np.__dict__:
        _np.bool = bool  # Debian Blender 3.4's glTF importer uses np.bool (removed in numpy 1.24)
except ImportError:
    pass

import bpy  # noqa: E402  (after the numpy shim on purpose)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser(prog="render_blender.py", description=__doc__.split("\n")[0])
    p.add_argument("input", help="the .glb or .gltf from `autoact export`")
    p.add_argument("output", help="folder for PNG frames, or the .mp4 with --video")
    p.add_argument("--engine", choices=["workbench", "cycles", "eevee"], default="workbench")
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--fps", type=float)
    p.add_argument("--frames", type=int)
    p.add_argument("--samples", type=int, default=16)
    p.add_argument("--threads", type=int)
    p.add_argument("--video", action="store_true", help="write an H.264 .mp4 instead of PNGs")
    return p.parse_args(argv)


def read_document(path):
    """The glTF JSON of a .gltf or .glb file (only the JSON: Blender reads the rest)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        length, kind = struct.unpack_from("<I4s", data, 12)
        if kind != b"JSON":
            raise SystemExit(f"{path}: the first GLB chunk is not JSON")
        return json.loads(data[20 : 20 + length])
    return json.loads(data)


def autoact_extras(doc):
    scenes = doc.get("scenes") or [{}]
    return ((scenes[doc.get("scene", 0)] or {}).get("extras") or {}).get("autoact", {})


def set_fps(scene, fps):
    # Blender stores the rate as fps / fps_base with an integer fps.
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps


def engine_name(engine):
    if engine == "workbench":
        return "BLENDER_WORKBENCH"
    if engine == "cycles":
        return "CYCLES"
    names = {e.identifier for e in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items}
    return "BLENDER_EEVEE_NEXT" if "BLENDER_EEVEE_NEXT" in names else "BLENDER_EEVEE"


def light_and_sky(scene, extras):
    lighting = None
    for s in extras.get("scenes", []):
        lighting = s.get("lighting")
        break
    if lighting:
        key_dir = lighting["key_dir_world"]
        key_rgb = lighting["key_rgb_linear"]
        zenith = lighting["zenith_rgb_linear"]
        horizon = lighting["horizon_rgb_linear"]
        strength = max(max(key_rgb), 1e-3)
        key_colour = [c / strength for c in key_rgb]
        sun_energy = 3.0 * strength
        sky = [(z + h) / 2 for z, h in zip(zenith, horizon)]
    else:
        # Default: an afternoon sun from the south-west, 45 degrees up; a pale blue sky.
        el, az = math.radians(45.0), math.radians(225.0)
        key_dir = [math.cos(el) * math.sin(az), math.cos(el) * math.cos(az), math.sin(el)]
        key_colour, sun_energy, sky = [1.0, 0.97, 0.92], 3.0, [0.45, 0.6, 0.85]
    sun_data = bpy.data.lights.new("sun", type="SUN")
    sun_data.energy = sun_energy
    sun_data.color = key_colour
    sun = bpy.data.objects.new("sun", sun_data)
    scene.collection.objects.link(sun)
    # A sun light shines down its local -z: point -z away from the direction towards the light.
    from mathutils import Vector

    sun.rotation_euler = Vector(key_dir).to_track_quat("Z", "Y").to_euler()
    world = bpy.data.worlds.new("sky")
    scene.world = world
    world.color = sky  # what Workbench shows behind the scene
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*sky, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    if scene.render.engine == "BLENDER_WORKBENCH":
        scene.display.shading.light = "STUDIO"
        scene.display.shading.color_type = "MATERIAL"
        scene.display.shading.background_type = "WORLD"
        scene.display.shading.show_shadows = True
        scene.display.light_direction = tuple(key_dir)


def ground(scene):
    mesh = bpy.data.meshes.new("ground")
    r = 50.0
    mesh.from_pydata([(-r, -r, 0), (r, -r, 0), (r, r, 0), (-r, r, 0)], [], [(0, 1, 2, 3)])
    material = bpy.data.materials.new("ground")
    material.diffuse_color = (0.45, 0.47, 0.42, 1.0)  # what Workbench shows
    material.use_nodes = True
    bsdf = material.node_tree.nodes.get("Principled BSDF")
    if bsdf is not None:
        bsdf.inputs["Base Color"].default_value = (0.35, 0.37, 0.33, 1.0)
    mesh.materials.append(material)
    obj = bpy.data.objects.new("ground", mesh)
    scene.collection.objects.link(obj)


def default_camera(scene, doc):
    """A camera 4 m in front of the character's first root position, at chest height, looking at
    the hips (autoact's rest pose faces +y)."""
    from mathutils import Vector

    hips = Vector((0.0, 0.0, 0.9))
    for obj in scene.objects:
        if obj.type == "ARMATURE":
            scene.frame_set(scene.frame_start)
            bone = obj.pose.bones.get("pelvis") or obj.pose.bones[0]
            hips = obj.matrix_world @ bone.head
            break
    data = bpy.data.cameras.new("camera")
    data.lens_unit = "FOV"
    data.angle = math.radians(50.0)
    cam = bpy.data.objects.new("camera", data)
    scene.collection.objects.link(cam)
    cam.location = hips + Vector((0.0, 4.0, 0.5))
    cam.rotation_euler = (hips - cam.location).to_track_quat("-Z", "Y").to_euler()
    return cam


def main():
    args = parse_args()
    doc = read_document(args.input)
    extras = autoact_extras(doc)
    fps = args.fps or float(extras.get("fps") or 30.0)
    frames = int(extras.get("frames") or 0)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    set_fps(scene, fps)  # BEFORE the import: the importer keys frames at the scene's rate
    bpy.ops.import_scene.gltf(filepath=os.path.abspath(args.input))
    print(f"render_blender: Blender {bpy.app.version_string}, imported {args.input}: "
          f"{sorted((o.name, o.type) for o in scene.objects)}")

    # The timeline: glTF time 0 is frame 0 (the importer keys k / fps seconds at frame k).
    if not frames:
        actions = [a.frame_range for a in bpy.data.actions]
        frames = int(round(max((r[1] for r in actions), default=0.0))) + 1
    if args.frames:
        frames = min(frames, args.frames)
    scene.frame_start, scene.frame_end = 0, frames - 1

    scene.render.engine = engine_name(args.engine)
    cameras = [o for o in scene.objects if o.type == "CAMERA"]
    scene.camera = cameras[0] if cameras else default_camera(scene, doc)
    light_and_sky(scene, extras)
    ground(scene)

    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = args.width, args.height, 100
    if args.threads:
        r.threads_mode, r.threads = "FIXED", args.threads
    scene.view_settings.view_transform = "Standard"
    if scene.render.engine == "CYCLES":
        scene.cycles.device = "CPU"
        scene.cycles.samples = args.samples
        scene.cycles.use_denoising = False
    elif scene.render.engine.startswith("BLENDER_EEVEE"):
        scene.eevee.taa_render_samples = args.samples

    if args.video:
        os.makedirs(os.path.dirname(os.path.abspath(args.output)), exist_ok=True)
        try:
            r.image_settings.media_type = "VIDEO"  # Blender 5.x
        except (AttributeError, TypeError):
            pass
        r.image_settings.file_format = "FFMPEG"
        r.ffmpeg.format = "MPEG4"
        r.ffmpeg.codec = "H264"
        r.use_file_extension = False
        r.filepath = os.path.abspath(args.output)
    else:
        os.makedirs(args.output, exist_ok=True)
        r.image_settings.file_format = "PNG"
        r.filepath = os.path.join(os.path.abspath(args.output), "frame_####")
    bpy.ops.render.render(animation=True)
    print(f"render_blender: {frames} frames at {fps} fps, {args.width}x{args.height}, "
          f"{scene.render.engine} -> {args.output}")


if __name__ == "__main__":
    main()
