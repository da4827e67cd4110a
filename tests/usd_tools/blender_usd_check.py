"""Imports an `mpm run --export-usd` stage into Blender with its own USD importer and prints what it
made, one JSON object: the objects, their types, and at the frames given the particles' count (a
point cloud), the surface's vertex and face counts and each collider's world position.

    python3 blender_usd_check.py STAGE.usda FRAME [FRAME ...]   (bpy, Blender as a Python module)
    blender -b --python blender_usd_check.py -- STAGE.usda FRAME ...

Blender 3.4 from Debian is built without USD (bpy.app.build_options.usd is False); PyPI's bpy
(Blender 5.0) has it.
"""

import json
import sys

import bpy


def main():
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    path, frames = args[0], [int(f) for f in args[1:]]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=path)
    scene = bpy.context.scene
    out = {
        "blender": bpy.app.version_string,
        "fps": scene.render.fps,
        "frame_range": [scene.frame_start, scene.frame_end],
        "objects": sorted([o.name, o.type] for o in bpy.data.objects),
        "frames": {},
    }
    for frame in frames:
        scene.frame_set(frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        seen = {}
        for o in bpy.data.objects:
            e = o.evaluated_get(depsgraph)
            if o.type == "POINTCLOUD":
                seen[o.name] = {"points": len(e.data.points)}
            elif o.type == "MESH":
                mesh = e.to_mesh()
                seen[o.name] = {
                    "vertices": len(mesh.vertices),
                    "faces": len(mesh.polygons),
                    "location": list(e.matrix_world.translation),
                }
                e.to_mesh_clear()
        out["frames"][str(frame)] = seen
    json.dump(out, sys.stdout)
    print()


main()
