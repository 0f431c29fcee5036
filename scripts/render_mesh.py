#!/usr/bin/python3
"""Render the boundary of a tetrahedral mesh to a PNG (the pictures in docs/images/).

Optional documentation helper: it is not a build, test or run-time dependency of shatter, and
nothing else uses it. It needs Python 3 with numpy, matplotlib (with Pillow) and meshio; on Debian
12: `apt-get install python3-matplotlib python3-meshio` and run it with the system interpreter,
`/usr/bin/python3 scripts/render_mesh.py ...`.

    scripts/render_mesh.py MESH [MESH ...] -o OUT [options]

MESH is anything meshio reads (.msh, .vtu, .vtk, ...). Tets: their boundary triangles (faces that
belong to one tet only) are drawn, oriented outwards. A surface mesh (.obj, .ply, .stl, e.g. from
`shatter convert MESH skin.obj`) is drawn as it is, so its triangles must wind outwards (those
facing away from the camera are not drawn). With --shatter PATH, a file meshio cannot read is
first converted with `PATH convert MESH tmp.vtu`. With one MESH, OUT is the PNG; with several, OUT
is a folder and each picture is OUT/<mesh name>.png.

Drawing: flat Lambert shading from a fixed light (above left, in front), orthographic camera at
--elev / --azim degrees (isometric-ish by default), equal scaling on all axes, no axes, white
background. --up y (default, the convention of assets/shapes) stands the mesh on its Y axis.
Output is deterministic: fixed size and dpi, no software/date metadata.

  --color-by NAME   colour each boundary triangle by the cell array NAME of its tet (e.g.
                    display_stress of fragments.vtu), diverging colormap centred at 0: tension
                    (positive) red, compression (negative) green; colorbar in Pa
  --unit TEXT       the unit of --color-by on the colorbar (default Pa)
  --color-cells NAME  colour each boundary triangle by the integer cell array NAME of its tet, one
                    colour per value (e.g. body in the frames of `shatter run`)
  --explode F       move each fragment (cell array fragment_id) away from the overall centroid by
                    F times its centroid's offset
  --edges           draw the triangle edges thinly
  --title TEXT      title; "{name}" is replaced by the mesh's file name without extension

The pictures in docs/images/ (docs/meshing.md):
    /usr/bin/python3 scripts/render_mesh.py assets/meshes/*.msh --edges --palette -o docs/images
    build/release/bin/shatter static examples/glass_bar/bar.vtk --case examples/glass_bar/case.json \
        --fracture --out /tmp/glass_bar
    /usr/bin/python3 scripts/render_mesh.py /tmp/glass_bar/fragments.vtu --color-by display_stress \
        --explode 0.25 --edges --edge-width 0.5 --azim -125 --size 800x360 --palette \
        -o docs/images/glass_bar_fragments.png
    build/release/bin/shatter run scenes/vase_drop.json --out /tmp/vase_drop
    /usr/bin/python3 scripts/render_mesh.py /tmp/vase_drop/frames/frame_000060.vtu --color-cells body \
        --edges --edge-width 0.2 --size 600x400 --palette -o docs/images/run_vase_drop.png
    (the same for block_on_block, frame 45; teddy_drops, frame 150, with --color-by plastic_strain --unit "")
"""

import argparse
import contextlib
import io
import os
import subprocess
import sys
import tempfile

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import LinearSegmentedColormap, Normalize  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

import meshio  # noqa: E402

TET_TYPES = ("tetra",)
TRI_TYPES = ("triangle",)
# Faces of tet (a, b, c, d) and, for each, the opposite vertex (used to orient the face outwards).
TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
TET_OPPOSITE = np.array([0, 1, 2, 3])

BASE_COLOR = np.array([0.78, 0.82, 0.88])  # light steel grey for plain meshes
# Diverging map: compression green, zero light grey, tension red (as docs/static_case.md).
STRESS_CMAP = LinearSegmentedColormap.from_list(
    "compression_tension", ["#1a9850", "#91cf60", "#eeeeee", "#fc8d59", "#d73027"])


def read_mesh(path, shatter):
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # meshio's Gmsh reader prints a blank line
            return meshio.read(path)
    except Exception as first:  # meshio does not know the format: let shatter convert it
        if not shatter:
            raise SystemExit(f"render_mesh.py: cannot read {path}: {first} (try --shatter PATH)")
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "mesh.vtu")
            subprocess.run([shatter, "convert", path, out], check=True, stdout=subprocess.DEVNULL)
            return meshio.read(out)


def cells_and_data(mesh, types):
    """Concatenate the cell blocks of the given types and their cell arrays, in block order."""
    blocks = [i for i, c in enumerate(mesh.cells) if c.type in types]
    if not blocks:
        return None, {}
    cells = np.concatenate([mesh.cells[i].data for i in blocks]).astype(np.int64)
    data = {}
    for name, arrays in mesh.cell_data.items():
        parts = [np.asarray(arrays[i]) for i in blocks]
        if all(p.ndim == 1 for p in parts):
            data[name] = np.concatenate(parts)
    return cells, data


def boundary_triangles(points, tets):
    """Boundary faces (those of one tet only), oriented outwards, and the tet of each."""
    faces = tets[:, TET_FACES].reshape(-1, 3)
    owner = np.repeat(np.arange(len(tets)), 4)
    opposite = tets[:, TET_OPPOSITE].reshape(-1)
    key = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    once = counts[inverse.reshape(-1)] == 1
    faces, owner, opposite = faces[once], owner[once], opposite[once]
    p = points[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    inward = np.einsum("ij,ij->i", normal, p.mean(axis=1) - points[opposite]) < 0
    faces[inward] = faces[inward][:, [0, 2, 1]]
    return faces, owner


def camera_basis(elev, azim):
    """Unit vectors towards the viewer, screen right and screen up, in matplotlib's frame."""
    e, a = np.radians(elev), np.radians(azim)
    back = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    up = np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])
    right = np.cross(up, back)
    return back, right, up


def render(path, out, args):
    mesh = read_mesh(path, args.shatter)
    points = np.asarray(mesh.points, dtype=float)
    if points.shape[1] == 2:
        points = np.hstack([points, np.zeros((len(points), 1))])
    tets, data = cells_and_data(mesh, TET_TYPES)
    if tets is not None:
        tris, owner = boundary_triangles(points, tets)
    else:
        tris, data = cells_and_data(mesh, TRI_TYPES)
        if tris is None:
            raise SystemExit(f"render_mesh.py: {path} has neither tetrahedra nor triangles")
        owner = np.arange(len(tris))

    # Stand the mesh up: matplotlib's vertical axis is Z (a proper rotation, so normals stay outward).
    if args.up == "y":
        points = points @ np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])
    elif args.up == "x":
        points = points @ np.array([[0, 0, 1.0], [0, 1, 0], [-1, 0, 0]])

    tri_points = points[tris]  # (n, 3, 3)
    if args.explode:
        if "fragment_id" not in data:
            raise SystemExit(f"render_mesh.py: --explode needs the cell array fragment_id in {path}")
        frag = data["fragment_id"][owner].astype(np.int64)
        used = np.unique(tris)
        centre = points[used].mean(axis=0)
        for k in np.unique(frag):
            sel = frag == k
            nodes = np.unique(tris[sel])
            tri_points[sel] += args.explode * (points[nodes].mean(axis=0) - centre)

    normal = np.cross(tri_points[:, 1] - tri_points[:, 0], tri_points[:, 2] - tri_points[:, 0])
    length = np.linalg.norm(normal, axis=1)
    keep = length > 0
    normal[keep] /= length[keep, None]

    back, right, up = camera_basis(args.elev, args.azim)
    keep &= normal @ back > 1e-9  # back faces are hidden by the front ones of a closed surface
    light = -0.45 * right + 0.65 * up + 0.85 * back
    light /= np.linalg.norm(light)
    shade = 0.42 + 0.58 * np.clip(normal @ light, 0.0, 1.0)

    values = None
    if args.color_cells:
        if args.color_cells not in data:
            names = ", ".join(sorted(data)) or "none"
            raise SystemExit(f"render_mesh.py: no cell array {args.color_cells} in {path} (has: {names})")
        labels = data[args.color_cells][owner].astype(np.int64)
        _, index = np.unique(labels, return_inverse=True)
        base = plt.get_cmap("tab10")(index % 10)[:, :3]
    elif args.color_by:
        if args.color_by not in data:
            names = ", ".join(sorted(data)) or "none"
            raise SystemExit(f"render_mesh.py: no cell array {args.color_by} in {path} (has: {names})")
        values = data[args.color_by][owner].astype(float)
        vmax = float(np.max(np.abs(values))) or 1.0
        norm = Normalize(-vmax, vmax)
        base = STRESS_CMAP(norm(values))[:, :3]
        shade = 0.5 + 0.5 * (shade - 0.42) / 0.58  # milder, so the colours stay readable
    if values is None and not args.color_cells:
        base = np.tile(BASE_COLOR, (len(tris), 1))
    face_rgb = np.clip(base * shade[:, None], 0.0, 1.0)

    tri_points, face_rgb = tri_points[keep], face_rgb[keep]
    width, height = args.size
    fig = plt.figure(figsize=(width / args.dpi, height / args.dpi), dpi=args.dpi, facecolor="white")
    colorbar = values is not None
    # The picture goes in the frame (the figure less the colorbar and title). The 3D axes are
    # larger than the frame so that nothing is clipped when they are moved to centre the mesh.
    frame = np.array([0.84 if colorbar else 1.0, 0.92 if args.title else 1.0])
    pad = 0.3 * frame
    ax = fig.add_axes([-pad[0], -pad[1], frame[0] + 2 * pad[0], frame[1] + 2 * pad[1]],
                      projection="3d", facecolor="white")
    ax.patch.set_visible(False)
    ax.set_proj_type("ortho")
    ax.view_init(elev=args.elev, azim=args.azim)
    if args.edges:
        edge_rgb = np.column_stack([face_rgb * 0.3, np.full(len(face_rgb), 0.75)])
        widths = args.edge_width
    else:  # edges in the face colour hide the hairline seams between triangles
        edge_rgb, widths = face_rgb, 0.3
    poly = Poly3DCollection(tri_points, facecolors=face_rgb, edgecolors=edge_rgb,
                            linewidths=widths, zsort="average")
    ax.add_collection3d(poly)

    lo, hi = tri_points.reshape(-1, 3).min(axis=0), tri_points.reshape(-1, 3).max(axis=0)
    extent = np.maximum(hi - lo, 1e-9 * max(np.max(hi - lo), 1e-300))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    # Equal scaling: the axes box has the data's proportions. Then zoom so that the mesh fills 92 %
    # of the frame (orthographic: its size is linear in the zoom) and move the axes to centre it.
    ax.set_box_aspect(extent, zoom=1.0)
    ax.set_axis_off()
    frame_px = frame * np.array([width, height])
    zoom = 1.0
    for _ in range(2):
        fig.canvas.draw()
        xy = display_xy(ax, tri_points.reshape(-1, 3))
        zoom *= 0.92 * float(np.min(frame_px / np.maximum(xy.max(axis=0) - xy.min(axis=0), 1e-9)))
        ax.set_box_aspect(extent, zoom=zoom)
    fig.canvas.draw()
    xy = display_xy(ax, tri_points.reshape(-1, 3))
    shift = (frame_px / 2 - (xy.max(axis=0) + xy.min(axis=0)) / 2) / np.array([width, height])
    pos = ax.get_position()
    ax.set_position([pos.x0 + shift[0], pos.y0 + shift[1], pos.width, pos.height])
    if args.zoom != 1.0:
        ax.set_box_aspect(extent, zoom=zoom * args.zoom)

    if args.title:
        fig.text(0.5, 0.965, args.title.replace("{name}", mesh_name(path)), ha="center", va="center",
                 fontsize=12)
    if colorbar:
        cax = fig.add_axes([0.86, 0.18, 0.03, 0.64])
        bar = fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=STRESS_CMAP), cax=cax)
        bar.set_label(f"{args.color_by} ({args.unit})" if args.unit else args.color_by)
        bar.formatter.set_powerlimits((-3, 4))
        bar.formatter.set_useMathText(True)
        bar.ax.tick_params(labelsize=8)
    fig.savefig(out, dpi=args.dpi, facecolor="white", metadata={"Software": None})
    plt.close(fig)
    if args.palette:
        quantize(out)
    print(f"{out}: {int(keep.sum())} of {len(tris)} boundary triangles drawn, {os.path.getsize(out)} bytes")


def display_xy(ax, xyz):
    """Pixel coordinates of data points under the axes' current projection."""
    from mpl_toolkits.mplot3d import proj3d

    x, y, _ = proj3d.proj_transform(xyz[:, 0], xyz[:, 1], xyz[:, 2], ax.get_proj())
    return ax.transData.transform(np.column_stack([x, y]))


def quantize(out):
    """Rewrite the PNG with a 256-colour palette (several times smaller)."""
    from PIL import Image

    with Image.open(out) as im:
        small = im.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    small.save(out, optimize=True)


def mesh_name(path):
    name = os.path.basename(path)
    for ext in (".vtu", ".vtk", ".msh", ".mesh", ".inp", ".obj", ".ply", ".stl"):
        if name.endswith(ext):
            return name[: -len(ext)]
    return os.path.splitext(name)[0]


def parse_size(text):
    try:
        w, h = (int(v) for v in text.lower().split("x"))
        assert w > 0 and h > 0
        return w, h
    except Exception:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels, got {text!r}")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("meshes", nargs="+", metavar="MESH")
    p.add_argument("-o", "--out", required=True, help="PNG file (one MESH) or folder (several)")
    p.add_argument("--color-by", metavar="NAME", help="cell array to colour by (diverging, centred at 0)")
    p.add_argument("--unit", default="Pa", help='unit of --color-by on the colorbar (default Pa; "" for none)')
    p.add_argument("--color-cells", metavar="NAME",
                   help="integer cell array to colour by, one colour per value (e.g. body of a shatter run frame)")
    p.add_argument("--explode", type=float, default=0.0, metavar="F", help="push fragments apart")
    p.add_argument("--edges", action="store_true", help="draw triangle edges")
    p.add_argument("--edge-width", type=float, default=0.3, metavar="PT", help="edge width (default 0.3 pt)")
    p.add_argument("--title", help='title ("{name}": the mesh file name)')
    p.add_argument("--up", choices=("x", "y", "z"), default="y", help="the mesh's vertical axis (default y)")
    p.add_argument("--elev", type=float, default=28.0, help="camera elevation, degrees (default 28)")
    p.add_argument("--azim", type=float, default=-55.0, help="camera azimuth, degrees (default -55)")
    p.add_argument("--zoom", type=float, default=1.0, help="scale the fitted picture (default 1)")
    p.add_argument("--size", type=parse_size, default=(600, 600), metavar="WxH", help="pixels (default 600x600)")
    p.add_argument("--dpi", type=int, default=100)
    p.add_argument("--palette", action="store_true", help="save as a 256-colour palette PNG (smaller)")
    p.add_argument("--shatter", metavar="PATH", help="shatter executable, to convert files meshio cannot read")
    args = p.parse_args()

    if len(args.meshes) == 1 and not os.path.isdir(args.out):
        render(args.meshes[0], args.out, args)
        return
    os.makedirs(args.out, exist_ok=True)
    for path in args.meshes:
        render(path, os.path.join(args.out, mesh_name(path) + ".png"), args)


if __name__ == "__main__":
    sys.exit(main())
