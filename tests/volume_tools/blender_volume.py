"""Opens `mpm run --export-volume` files in Blender and prints what Blender made of each; with
--render, also renders the last one's water surface (Cycles) to a PNG.

    blender -b --python tests/volume_tools/blender_volume.py -- out/vol/volume_000020.vdb
    blender -b --python tests/volume_tools/blender_volume.py -- --render out.png FILE.vdb

What a user does by hand: File > Import > OpenVDB (.vdb) makes a Volume object whose grids Blender
lists (its volume shader draws `density` as a fog); a Volume to Mesh modifier on the grid `surface`
on a mesh object, reading the volume object, makes the level set's zero a mesh. The simulation's y is up, Blender's z: the volume object is
turned 90 degrees about X (the modifier's mesh follows it). Checked with Blender 3.4.1 (Debian's package, on OpenVDB 10.0.1).
"""
import math
import os
import sys

import bmesh
import bpy

args = sys.argv[sys.argv.index("--") + 1:]
render_to = None
if args and args[0] == "--render":
    render_to, args = args[1], args[2:]

for path in args:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.object.volume_import(filepath=path, files=[{"name": path.split("/")[-1]}],
                                 directory=path.rsplit("/", 1)[0] + "/")
    volume = bpy.context.selected_objects[0]
    volume.rotation_euler = (math.pi / 2, 0, 0)
    grids = volume.data.grids
    grids.load()
    print(f"{path}: Blender's volume object '{volume.name}', grids loaded {grids.is_loaded}, "
          f"error '{grids.error_message}'")
    for grid in grids:
        print(f"  grid {grid.name}: data type {grid.data_type}, {grid.channels} channel(s)")
    # Volume to Mesh is a mesh object's modifier that reads a volume object.
    water = bpy.data.objects.new("water", bpy.data.meshes.new("water"))
    bpy.context.collection.objects.link(water)
    modifier = water.modifiers.new("surface", "VOLUME_TO_MESH")
    modifier.object = volume
    modifier.grid_name = "surface"
    modifier.resolution_mode = "GRID"
    modifier.threshold = 0.0
    modifier.use_smooth_shade = True
    volume.hide_render = True
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = water.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    bm = bmesh.new()
    bm.from_mesh(mesh)
    bpy.context.view_layer.update()
    bm.transform(water.matrix_world)
    lo = [min(v.co[a] for v in bm.verts) for a in range(3)] if bm.verts else [0, 0, 0]
    hi = [max(v.co[a] for v in bm.verts) for a in range(3)] if bm.verts else [0, 0, 0]
    print(f"  Volume to Mesh on 'surface': {len(mesh.vertices)} vertices, {len(mesh.polygons)} faces, "
          f"volume {abs(bm.calc_volume(signed=True)):.4e} m^3, Blender's box (z up) "
          f"{[round(x, 3) for x in lo]} to {[round(x, 3) for x in hi]}")
    bm.free()
    evaluated.to_mesh_clear()
    if not render_to:
        bpy.data.objects.remove(water)



def principled(name, colour):
    """A material of one Principled BSDF (made here: the node names of a new material vary)."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    out = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    bsdf.inputs["Base Color"].default_value = colour
    return material, bsdf


if render_to:
    scene = bpy.context.scene
    material, bsdf = principled("water", (0.04, 0.22, 0.55, 1.0))
    # Opaque and glossy: the shape reads at a few samples, where glass would be noise.
    bsdf.inputs["Roughness"].default_value = 0.15
    bsdf.inputs["IOR"].default_value = 1.33
    water.data.materials.append(material)
    # The tank: a floor and two walls (the domain is 1 x 0.5 x 0.5 m, y up: Blender's x, z, -y).
    tank, _ = principled("tank", (0.8, 0.8, 0.78, 1.0))
    for size, location, rotation in [
        ((1.0, 0.5), (0.5, -0.25, 0.0), (0, 0, 0)),
        ((1.0, 0.5), (0.5, 0.0, 0.25), (math.pi / 2, 0, 0)),
        ((0.5, 0.5), (1.0, -0.25, 0.25), (0, math.pi / 2, 0)),
    ]:
        bpy.ops.mesh.primitive_plane_add(size=1, location=location, rotation=rotation)
        plane = bpy.context.object
        plane.scale = (size[0], size[1], 1)
        plane.data.materials.append(tank)
    bpy.ops.object.light_add(type="SUN", rotation=(math.radians(40), math.radians(-20), math.radians(30)))
    bpy.context.object.data.energy = 3.0
    bpy.ops.object.camera_add(location=(1.35, -1.55, 0.95))
    camera = bpy.context.object
    bpy.ops.object.empty_add(location=(0.5, -0.25, 0.1))
    aim = camera.constraints.new("TRACK_TO")
    aim.target = bpy.context.object
    aim.track_axis, aim.up_axis = "TRACK_NEGATIVE_Z", "UP_Y"
    scene.camera = camera
    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    nodes = world.node_tree.nodes
    nodes.clear()
    background = nodes.new("ShaderNodeBackground")
    background.inputs["Color"].default_value = (0.7, 0.8, 0.9, 1.0)
    background.inputs["Strength"].default_value = 0.8
    world.node_tree.links.new(background.outputs["Background"], nodes.new("ShaderNodeOutputWorld").inputs["Surface"])
    scene.world = world
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = int(os.environ.get("SAMPLES", "32"))
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 960, 540
    scene.render.resolution_percentage = int(os.environ.get("PERCENT", "100"))
    scene.render.filepath = render_to
    bpy.ops.render.render(write_still=True)
    print(f"rendered {render_to}")
