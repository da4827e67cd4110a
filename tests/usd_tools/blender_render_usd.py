"""Renders one frame of an `mpm run --export-usd` stage with Blender's Cycles on the CPU, headless:
the stage imported by Blender's own USD importer (the surface mesh, the colliders and bodies; the
particles' point cloud hidden), a floor, a sun and a camera looking into the tank.

    python3 blender_render_usd.py STAGE.usda FRAME OUT.png [WIDTHxHEIGHT] [SAMPLES]   (PyPI's bpy)

The picture in docs/ (docs/export.md, "USD"), frame 48 of the coarse dam break with a static box and
a floating one (about a minute and a half on 2 cores):

    mpm run --scene tests/usd_tools/dam-break-coarse-bodies.toml --frames 48 --every 6 \
        --export-usd dam.usda --usd-surface --surface-smoothing-length 4 --surface-cube-size 0.5
    python3 tests/usd_tools/blender_render_usd.py dam.usda 48 docs/usd-dam-break-blender.png
"""

import math
import sys

import bpy


def main():
    path, frame, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    width, height = (int(x) for x in (sys.argv[4] if len(sys.argv) > 4 else "960x540").split("x"))
    samples = int(sys.argv[5]) if len(sys.argv) > 5 else 64
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.usd_import(filepath=path)
    scene = bpy.context.scene
    scene.frame_set(frame)

    water = bpy.data.materials.new("water")
    water.use_nodes = True
    bsdf = water.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.10, 0.35, 0.80, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.05
    # Half see-through, so the bodies under the surface show.
    bsdf.inputs["Transmission Weight"].default_value = 0.6
    bsdf.inputs["IOR"].default_value = 1.33
    solid = bpy.data.materials.new("collider")
    solid.use_nodes = True
    solid.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.8, 0.35, 0.1, 1.0)
    for o in bpy.data.objects:
        if o.type == "POINTCLOUD":
            o.hide_render = True
        elif o.type == "MESH":
            o.data.materials.clear()
            o.data.materials.append(water if o.name == "Surface" else solid)

    # The tank's floor; the stage is y up, which Blender's importer turns to z up (y_usd -> z).
    bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.5, -0.25, 0.0))
    floor = bpy.context.object
    floor.scale = (1.0, 0.5, 1.0)
    grey = bpy.data.materials.new("floor")
    grey.use_nodes = True
    grey.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.8, 0.8, 0.78, 1.0)
    floor.data.materials.append(grey)

    bpy.ops.object.light_add(type="SUN", rotation=(math.radians(40), math.radians(10), math.radians(30)))
    bpy.context.object.data.energy = 3.0
    world = bpy.data.worlds.new("sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.55, 0.6, 0.7, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.8
    scene.world = world

    bpy.ops.object.camera_add(location=(1.05, -1.1, 0.62), rotation=(math.radians(63), 0, math.radians(35)))
    scene.camera = bpy.context.object
    scene.camera.data.lens = 30

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = True
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.filepath = out
    bpy.ops.render.render(write_still=True)
    print(f"wrote {out}")


main()
