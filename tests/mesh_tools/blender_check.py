"""Imports mesh files with Blender's own importers and prints what Blender made of each:

    blender -b --python tests/mesh_tools/blender_check.py -- surface_000000.obj surface_000000.ply

OBJ through File > Import > Wavefront (.obj) (bpy.ops.wm.obj_import, Blender 3.2 and later), PLY
through File > Import > Stanford (.ply). Checked with Blender 3.4.1 (Debian's package).
"""
import sys

import bmesh
import bpy

for path in sys.argv[sys.argv.index("--") + 1:]:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if path.endswith(".obj"):
        bpy.ops.wm.obj_import(filepath=path)
    else:
        bpy.ops.import_mesh.ply(filepath=path)
    obj = bpy.context.selected_objects[0]
    mesh = obj.data
    bm = bmesh.new()
    bm.from_mesh(mesh)
    bm.transform(obj.matrix_world)  # the OBJ importer turns Y-up files to Blender's Z-up
    closed = all(e.is_manifold and e.is_contiguous for e in bm.edges)
    print(f"{path}: {len(mesh.vertices)} vertices, {len(mesh.polygons)} faces, "
          f"all triangles {all(len(p.vertices) == 3 for p in mesh.polygons)}, "
          f"every edge between two faces wound alike {closed}, "
          f"signed volume {bm.calc_volume(signed=True):.4e} m^3, "
          f"file normals used {mesh.has_custom_normals}")
    bm.free()
