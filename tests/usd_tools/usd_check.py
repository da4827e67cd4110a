"""Reads an `mpm run --export-usd` stage with Pixar's USD library (pxr, from the usd-core wheel) and
prints what it finds as one JSON object, for tests/usd_readers.rs to hold against the run's PLY
frames, surface meshes and pose table.

    python3 usd_check.py STAGE.usda FRAME [FRAME ...]

For the stage: its metadata and the time samples of the particles' points. For each FRAME (a time
code): the particles' arrays, the surface mesh's (where the stage has one), and each collider's
transform ops and its mesh's points in world space (its local-to-world transform applied by USD).
"""

import json
import sys

from pxr import Gf, Usd, UsdGeom


def floats(values):
    return [float(x) for x in values]


def vectors(values):
    return [[float(c) for c in v] for v in values]


def main():
    path, frames = sys.argv[1], [float(f) for f in sys.argv[2:]]
    stage = Usd.Stage.Open(path)
    if stage is None:
        raise SystemExit(f"USD cannot open {path}")
    particles = UsdGeom.Points(stage.GetPrimAtPath("/Sim/Particles"))
    surface_prim = stage.GetPrimAtPath("/Sim/Surface")
    primvars = UsdGeom.PrimvarsAPI(particles.GetPrim())
    out = {
        "default_prim": stage.GetDefaultPrim().GetPath().pathString,
        "start": stage.GetStartTimeCode(),
        "end": stage.GetEndTimeCode(),
        "time_codes_per_second": stage.GetTimeCodesPerSecond(),
        "frames_per_second": stage.GetFramesPerSecond(),
        "up_axis": str(UsdGeom.GetStageUpAxis(stage)),
        "meters_per_unit": UsdGeom.GetStageMetersPerUnit(stage),
        "point_samples": particles.GetPointsAttr().GetTimeSamples(),
        "widths": floats(particles.GetWidthsAttr().Get()),
        "widths_interpolation": str(particles.GetWidthsInterpolation()),
        "primvars": sorted(
            [p.GetPrimvarName(), str(p.GetInterpolation())] for p in primvars.GetAuthoredPrimvars()
        ),
        "material_names": list(particles.GetPrim().GetAttribute("mpm:materialNames").Get()),
        "has_surface": surface_prim.IsValid(),
        "frames": {},
    }
    cache = UsdGeom.XformCache()
    for t in frames:
        frame = {}
        frame["points"] = vectors(particles.GetPointsAttr().Get(t))
        frame["velocities"] = vectors(particles.GetVelocitiesAttr().Get(t))
        frame["extent"] = vectors(particles.GetExtentAttr().Get(t))
        for name in ["density", "material", "J", "von_mises"]:
            primvar = primvars.GetPrimvar(name)
            if primvar.IsDefined():
                value = primvar.Get(t)
                frame[name] = [int(x) for x in value] if name == "material" else floats(value)
        if surface_prim.IsValid():
            mesh = UsdGeom.Mesh(surface_prim)
            counts = mesh.GetFaceVertexCountsAttr().Get(t)
            frame["surface"] = {
                "points": vectors(mesh.GetPointsAttr().Get(t)),
                "normals": len(mesh.GetNormalsAttr().Get(t)),
                "faces": len(counts),
                "all_triangles": all(c == 3 for c in counts),
                "indices": [int(i) for i in mesh.GetFaceVertexIndicesAttr().Get(t)],
                "subdivision": str(mesh.GetSubdivisionSchemeAttr().Get()),
            }
        colliders = {}
        cache.SetTime(Usd.TimeCode(t))
        scope = stage.GetPrimAtPath("/Sim/Colliders")
        for prim in scope.GetChildren() if scope.IsValid() else []:
            mesh = UsdGeom.Mesh(prim)
            xform = cache.GetLocalToWorldTransform(prim)
            translate = prim.GetAttribute("xformOp:translate").Get(t)
            orient = prim.GetAttribute("xformOp:orient").Get(t)
            colliders[prim.GetName()] = {
                # Doubles as their shortest text (repr), which a JSON reader may not parse to the bit.
                "translate": [repr(float(c)) for c in translate],
                # (x, y, z, w), as the pose table.
                "orient": [repr(float(c)) for c in orient.GetImaginary()] + [repr(float(orient.GetReal()))],
                "time_varying": prim.GetAttribute("xformOp:translate").ValueMightBeTimeVarying(),
                "world_points": [list(xform.Transform(Gf.Vec3d(p))) for p in mesh.GetPointsAttr().Get(t)],
                "faces": len(mesh.GetFaceVertexCountsAttr().Get(t)),
            }
        frame["colliders"] = colliders
        out["frames"][str(int(t))] = frame
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
