"""Reads a .vdb file with OpenVDB's own library (its Python bindings) and compares every voxel of a
box with the values and active states the writer expected; prints one JSON object per grid.

    python3 tests/volume_tools/openvdb_check.py FILE.vdb EXPECTED_DIR

EXPECTED_DIR holds expected.json ({"box_min": [i, j, k], "shape": [nx, ny, nz], "grids": [names]})
and, per grid, NAME.values (little-endian float32, x slowest, z fastest; three per voxel for a
vector grid) and NAME.active (one byte per voxel). tests/volume_readers.rs writes them and reads
what this prints. Works with OpenVDB 10's `pyopenvdb` (Debian's python3-openvdb) and the
`openvdb` module of OpenVDB 11 and later.
"""
import json
import os
import sys

import numpy as np

try:
    import pyopenvdb as vdb
except ImportError:
    import openvdb as vdb

path, expected_dir = sys.argv[1], sys.argv[2]
with open(os.path.join(expected_dir, "expected.json")) as f:
    expected = json.load(f)
box_min = tuple(expected["box_min"])
shape = tuple(expected["shape"])
grids, file_metadata = vdb.readAll(path)
print(json.dumps({
    "file_metadata": {k: (v if isinstance(v, (int, float, str, bool)) else str(v))
                      for k, v in file_metadata.items()},
    "library": list(vdb.LIBRARY_VERSION),
}))
by_name = {g.name: g for g in grids}
for name in expected["grids"]:
    grid = by_name[name]
    vector = grid.valueTypeName == "vec3s"
    dense_shape = shape + ((3,) if vector else ())
    values = np.zeros(dense_shape, dtype=np.float32)
    grid.copyToArray(values, ijk=box_min)
    want = np.fromfile(os.path.join(expected_dir, name + ".values"), dtype="<f4").reshape(dense_shape)
    # Active voxels (and active tiles, none here) as OpenVDB iterates them.
    active = np.zeros(shape, dtype=bool)
    for item in grid.iterOnValues():
        lo = [max(a - b, 0) for a, b in zip(item.min, box_min)]
        hi = [min(a - b + 1, n) for a, b, n in zip(item.max, box_min, shape)]
        if all(l < h for l, h in zip(lo, hi)):
            active[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] = True
    want_active = np.fromfile(os.path.join(expected_dir, name + ".active"), dtype=np.uint8).reshape(shape) != 0
    differ = values != want
    if vector:
        differ = differ.any(axis=-1)
    bbox = grid.evalActiveVoxelBoundingBox()
    print(json.dumps({
        "name": name,
        "value_type": grid.valueTypeName,
        "class": grid.gridClass,
        "vector_type": grid.vectorType,
        "half": grid.saveFloatAsHalf,
        "background": list(grid.background) if vector else grid.background,
        "voxel_size": list(grid.transform.voxelSize()),
        "active_voxels": grid.activeVoxelCount(),
        "bbox": [list(bbox[0]), list(bbox[1])],
        "voxels_compared": int(np.prod(shape)),
        "values_differing": int(differ.sum()),
        "max_difference": float(np.abs(values - want).max()),
        "active_differing": int((active != want_active).sum()),
        "metadata": {k: str(v) for k, v in grid.metadata.items()},
    }))
    if grid.gridClass == "level set":
        # OpenVDB's own mesher on the level set's zero: the liquid's volume, by the divergence
        # theorem over its triangles and quads (split in two).
        points, triangles, quads = grid.convertToPolygons(isovalue=0.0, adaptivity=0.0)
        tris = [triangles.reshape(-1, 3)]
        if len(quads):
            quads = quads.reshape(-1, 4)
            tris += [quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]
        tris = np.concatenate(tris).astype(np.int64)
        p = points.astype(np.float64)
        a, b, c = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
        volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)
        print(json.dumps({"name": name, "mesh_points": len(points), "mesh_polygons": len(tris),
                          "mesh_volume": abs(volume)}))
