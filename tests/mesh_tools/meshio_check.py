"""Reads mesh files with meshio and prints one JSON object per file: what meshio made of it.

    python3 tests/mesh_tools/meshio_check.py surface_000000.obj surface_000000.ply ...

tests/mesh_readers.rs runs it on the three formats of `mpm run --export-surface`.
"""
import json
import sys

import meshio
import numpy as np

for path in sys.argv[1:]:
    mesh = meshio.read(path)
    triangles = mesh.cells_dict.get("triangle", np.zeros((0, 3), dtype=int))
    a, b, c = (mesh.points[triangles[:, k]] for k in range(3))
    # Divergence theorem: the signed tetrahedra (origin, a, b, c); positive for outward winding.
    volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6)
    normals = {name: list(np.shape(data)) for name, data in mesh.point_data.items()}
    print(json.dumps({
        "path": path,
        "points": len(mesh.points),
        "cell_types": [block.type for block in mesh.cells],
        "triangles": len(triangles),
        "signed_volume": volume,
        "point_data": normals,
    }))
