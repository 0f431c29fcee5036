#!/usr/bin/env python3
"""Write a box tetrahedral mesh as legacy VTK (ASCII): nx*ny*nz cells, each cut into 6 tets around
its main diagonal (the same pattern as shatter's make_box_mesh). Nodes numbered x fastest.

usage: make_box_mesh.py OUT.vtk LX LY LZ NX NY NZ
"""
import itertools
import sys


def main():
    if len(sys.argv) != 8:
        sys.exit(__doc__)
    out = sys.argv[1]
    size = [float(v) for v in sys.argv[2:5]]
    cells = [int(v) for v in sys.argv[5:8]]
    n = [c + 1 for c in cells]

    def node(i, j, k):
        return i + n[0] * (j + n[1] * k)

    points = [(size[0] * i / cells[0], size[1] * j / cells[1], size[2] * k / cells[2])
              for k in range(n[2]) for j in range(n[1]) for i in range(n[0])]
    tets = []
    for k, j, i in itertools.product(range(cells[2]), range(cells[1]), range(cells[0])):
        for perm in itertools.permutations(range(3)):
            c = [i, j, k]
            corners = [node(*c)]
            for axis in perm:
                c[axis] += 1
                corners.append(node(*c))
            a, b, cc, d = (points[v] for v in corners)
            e1 = [b[t] - a[t] for t in range(3)]
            e2 = [cc[t] - a[t] for t in range(3)]
            e3 = [d[t] - a[t] for t in range(3)]
            det = (e1[0] * (e2[1] * e3[2] - e2[2] * e3[1]) - e1[1] * (e2[0] * e3[2] - e2[2] * e3[0]) +
                   e1[2] * (e2[0] * e3[1] - e2[1] * e3[0]))
            if det < 0:
                corners[1], corners[2] = corners[2], corners[1]
            tets.append(corners)
    with open(out, "w") as f:
        f.write("# vtk DataFile Version 4.2\nbox mesh\nASCII\nDATASET UNSTRUCTURED_GRID\n")
        f.write("POINTS %d double\n" % len(points))
        for p in points:
            f.write("%.17g %.17g %.17g\n" % p)
        f.write("CELLS %d %d\n" % (len(tets), 5 * len(tets)))
        for t in tets:
            f.write("4 %d %d %d %d\n" % tuple(t))
        f.write("CELL_TYPES %d\n" % len(tets))
        f.write("10\n" * len(tets))


if __name__ == "__main__":
    main()
