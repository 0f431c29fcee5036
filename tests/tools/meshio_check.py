"""Cross-check helper for the mesh readers and writers, driven by tests/mesh/test_io_meshio.cpp.

  meshio_check.py write IN.json OUT FORMAT [binary]  # meshio writes the mesh in IN.json
                                                    # (FORMAT vtu_default: meshio's default VTU)
  meshio_check.py read PATH                         # meshio reads PATH, prints points and tets as JSON

IN.json: {"points": [[x, y, z], ...], "tets": [[a, b, c, d], ...]} (0-based).
"""
import json
import sys
import warnings

import meshio
import numpy as np


def main():
    warnings.simplefilter("ignore")
    if sys.argv[1] == "write":
        with open(sys.argv[2]) as f:
            data = json.load(f)
        points = np.array(data["points"], dtype=np.float64)
        tets = np.array(data["tets"], dtype=np.int64)
        fmt = sys.argv[4]
        binary = len(sys.argv) > 5 and sys.argv[5] == "binary"
        cell_data = {}
        if fmt.startswith("gmsh"):
            ones = np.ones(len(tets), dtype=np.int32)
            cell_data = {"gmsh:physical": [ones], "gmsh:geometrical": [ones]}
        mesh = meshio.Mesh(points, [("tetra", tets)], cell_data=cell_data)
        kwargs = {}
        if fmt in ("gmsh22", "gmsh", "vtk"):
            kwargs["binary"] = binary
        if fmt == "vtu":
            kwargs["binary"] = binary
            kwargs["compression"] = None
        if fmt == "vtu_default":  # meshio's defaults: inline base64, zlib-compressed
            fmt = "vtu"
        meshio.write(sys.argv[3], mesh, file_format=fmt, **kwargs)
    else:
        mesh = meshio.read(sys.argv[2])
        tets = [c.data.tolist() for c in mesh.cells if c.type == "tetra"]
        out = {"points": mesh.points.tolist(), "tets": [t for block in tets for t in block]}
        json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
