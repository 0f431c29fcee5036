"""Writes the VTU fixtures of this folder with meshio and with VTK's own XML writer (the one
ParaView uses), so tests/mesh/test_io_vtu.cpp can check that we read what they write, bit for bit,
without either being installed at test time. Run once from this folder (Debian 12):

  apt-get install python3-meshio python3-vtk9
  /usr/bin/python3 make_fixtures.py

expected.json holds the mesh (points as Python's shortest round-trip text, so they parse back to the
same doubles; tets 0-based). The files:
  meshio_default.vtu      meshio.write defaults: inline base64, zlib, UInt32 headers
  meshio_uint64.vtu       the same with header_type="UInt64"
  meshio_uncompressed.vtu binary=True, compression=None: inline base64, no compression
  vtk_default.vtu         vtkXMLUnstructuredGridWriter defaults (VTK 9.1): appended base64, zlib,
                          UInt32 headers
  vtk_appended_raw.vtu    EncodeAppendedDataOff(), UInt64 headers (ParaView's defaults): appended
                          raw, zlib
  vtk_inline_binary.vtu   SetDataModeToBinary(): inline base64, zlib
  vtk_appended_plain.vtu  EncodeAppendedDataOff(), SetCompressorTypeToNone(): appended raw,
                          uncompressed
  vtk_small_blocks.vtu    EncodeAppendedDataOff(), SetBlockSize(64): appended raw, zlib, many blocks
"""
import json
import math

import meshio
import numpy as np
import vtk
from vtk.util import numpy_support


def make_mesh():
    # A 3 x 2 x 2 grid of cubes, each split into 6 tets around its main diagonal (Kuhn), with the
    # interior points moved by irrational amounts so every coordinate uses all 53 bits.
    nx, ny, nz = 3, 2, 2
    def pid(i, j, k):
        return i + (nx + 1) * (j + (ny + 1) * k)
    points = []
    for k in range(nz + 1):
        for j in range(ny + 1):
            for i in range(nx + 1):
                s = pid(i, j, k) + 1
                points.append([0.7 * i + 0.05 * math.sin(1.3 * s), 0.9 * j + 0.05 * math.cos(2.1 * s),
                               1.1 * k + 0.04 * math.sin(0.7 * s) - 3.0])
    tets = []
    paths = [(1, 2, 4), (1, 4, 2), (2, 1, 4), (2, 4, 1), (4, 1, 2), (4, 2, 1)]
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                for path in paths:
                    c = [0, 0, 0]
                    t = [pid(i, j, k)]
                    for step in path:
                        c[{1: 0, 2: 1, 4: 2}[step]] += 1
                        t.append(pid(i + c[0], j + c[1], k + c[2]))
                    a, b, cc, d = (np.array(points[v]) for v in t)
                    if np.dot(np.cross(b - a, cc - a), d - a) < 0:
                        t[2], t[3] = t[3], t[2]
                    tets.append(t)
    return np.array(points, dtype=np.float64), np.array(tets, dtype=np.int64)


def write_vtk(path, points, tets, setup):
    grid = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints()
    pts.SetDataTypeToDouble()
    pts.SetData(numpy_support.numpy_to_vtk(points, deep=True))
    grid.SetPoints(pts)
    for t in tets:
        ids = vtk.vtkIdList()
        for v in t:
            ids.InsertNextId(int(v))
        grid.InsertNextCell(vtk.VTK_TETRA, ids)
    w = vtk.vtkXMLUnstructuredGridWriter()
    w.SetFileName(path)
    w.SetInputData(grid)
    setup(w)
    assert w.Write() == 1


def main():
    points, tets = make_mesh()
    with open("expected.json", "w") as f:
        json.dump({"points": [[repr(float(x)) for x in p] for p in points], "tets": tets.tolist()}, f)
        f.write("\n")
    mesh = meshio.Mesh(points, [("tetra", tets)])
    meshio.write("meshio_default.vtu", mesh)
    meshio.vtu.write("meshio_uint64.vtu", mesh, header_type="UInt64")
    meshio.write("meshio_uncompressed.vtu", mesh, binary=True, compression=None)
    write_vtk("vtk_default.vtu", points, tets, lambda w: None)
    def raw64(w):
        w.EncodeAppendedDataOff()
        w.SetHeaderTypeToUInt64()
    write_vtk("vtk_appended_raw.vtu", points, tets, raw64)
    write_vtk("vtk_inline_binary.vtu", points, tets, lambda w: w.SetDataModeToBinary())
    def plain(w):
        w.EncodeAppendedDataOff()
        w.SetCompressorTypeToNone()
    write_vtk("vtk_appended_plain.vtu", points, tets, plain)
    def small(w):
        w.EncodeAppendedDataOff()
        w.SetBlockSize(64)
    write_vtk("vtk_small_blocks.vtu", points, tets, small)


if __name__ == "__main__":
    main()
