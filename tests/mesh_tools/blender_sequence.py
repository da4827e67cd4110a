"""Imports a folder of `mpm run --export-surface` meshes into Blender as one animation: one object per
file, each shown (viewport and render) from its own frame until the next file's frame, at 60 fps.

In Blender's Scripting workspace, open this file, set FOLDER, and Run Script; or from a shell:

    blender --python tests/mesh_tools/blender_sequence.py -- out/surface

Without the "--" argument it imports FOLDER below. The simulation's y axis is up; Blender's z is,
so every mesh is turned to stand upright (the OBJ importer does that itself; PLY is turned here).
Checked headless with Blender 3.4.1 (`blender -b`).
"""
import math
import re
import sys
from pathlib import Path

import bpy

FOLDER = "out/surface"
if "--" in sys.argv:
    FOLDER = sys.argv[sys.argv.index("--") + 1]

files = sorted(p for p in Path(FOLDER).iterdir() if re.fullmatch(r"surface_\d+\.(obj|ply)", p.name))
if not files:
    raise SystemExit(f"no surface_NNNNNN.obj or .ply files in {FOLDER}")
frames = [int(re.search(r"\d+", p.name).group()) for p in files]
collection = bpy.data.collections.new("mpm surface")
bpy.context.scene.collection.children.link(collection)
for i, (path, frame) in enumerate(zip(files, frames)):
    if path.suffix == ".obj":
        bpy.ops.wm.obj_import(filepath=str(path))
    else:
        bpy.ops.import_mesh.ply(filepath=str(path))
    obj = bpy.context.selected_objects[0]
    if path.suffix == ".ply":
        obj.rotation_euler[0] = math.pi / 2  # y up in the file, z up in Blender
    for c in obj.users_collection:
        c.objects.unlink(obj)
    collection.objects.link(obj)
    # Blender counts frames from 1: simulation frame f is Blender frame f + 1.
    first = frame + 1
    last = frames[i + 1] if i + 1 < len(frames) else first
    for hidden, at in [(True, first - 1), (False, first), (True, last + 1)]:
        obj.hide_viewport = obj.hide_render = hidden
        obj.keyframe_insert("hide_viewport", frame=at)
        obj.keyframe_insert("hide_render", frame=at)
scene = bpy.context.scene
scene.render.fps = 60
scene.frame_start, scene.frame_end = frames[0] + 1, frames[-1] + 1
scene.frame_set(scene.frame_start)
print(f"imported {len(files)} meshes from {FOLDER}: Blender frames {scene.frame_start} to {scene.frame_end}")
