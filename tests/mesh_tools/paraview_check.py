"""Opens mesh files with ParaView's own readers and prints what ParaView read, per time step:

    pvbatch tests/mesh_tools/paraview_check.py "out/surface_*.ply" "out/surface_*.vtk"

Each pattern is opened as one file series, as File > Open opens a grouped sequence; where the
reader takes one file only (ParaView 5.11's OBJ reader), the first file. Checked with ParaView
5.11.0 (Debian's paraview and python3-paraview packages; pvbatch is pvbatch3.11 there).
"""
import sys, glob
from paraview.simple import OpenDataFile, servermanager
for pattern in sys.argv[1:]:
    files = sorted(glob.glob(pattern))
    try:
        reader = OpenDataFile(files)
        series = f"a series of {len(files)} files"
    except RuntimeError as e:
        reader = OpenDataFile(files[0])
        series = f"one file only ({e})"
    times = list(getattr(reader, "TimestepValues", None) or [None])
    for t in times:
        reader.UpdatePipeline(t) if t is not None else reader.UpdatePipeline()
        data = servermanager.Fetch(reader)
        pd = data.GetPointData()
        arrays = [pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())]
        print(f"{pattern}: {reader.GetXMLName()}, {series}, time {t}: {data.GetNumberOfPoints()} points, "
              f"{data.GetNumberOfCells()} cells, point arrays {arrays}, normals {pd.GetNormals() is not None}")
