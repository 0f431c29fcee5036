// Reading and writing tetrahedral meshes and boundary surfaces, format chosen by file extension.
//
// Read:  .msh (Gmsh 2.2 / 4.1, ASCII / binary), .node + .ele (TetGen), .vtk (legacy 4.2 / 5.1,
//        ASCII / binary), .vtu (VTK XML), .mesh (MEDIT), .inp (Abaqus / CalculiX subset).
// Write: the same volume formats (.msh written as 4.1), plus boundary surfaces .obj, .ply, .stl.
// docs/formats.md lists what each reader accepts and the limits.
//
// Every reader parses bytes already in memory (so fuzzers and tests can feed it directly), checks
// every count against the bytes that remain before allocating, and returns an Error with the file,
// line (text) or byte offset (binary) and what was expected. Every writer streams into an
// std::ostream; write_mesh() / write_surface() put the result in place atomically.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/mesh/tet_mesh.h"
#include "shatter/mesh/topology.h"

namespace shatter {

/// A mesh as read, with notes on what the file held that is not a linear tet.
struct MeshReadResult {
  TetMesh mesh;                      ///< the linear tets with their nodes, ids, tags and sets
  std::string format;                ///< "msh 4.1 binary", "vtk 5.1 ascii", ...
  std::vector<std::string> skipped;  ///< e.g. "120 triangles (gmsh type 2)", one line per kind
};

/// Per-node or per-tet data written alongside a mesh (VTU / VTK point or cell data).
struct MeshField {
  std::string name;            ///< array name in the file
  int components = 1;          ///< 1 (scalar), 3 (vector), 6 (symmetric tensor xx yy zz xy yz zx) ...
  std::vector<double> values;  ///< (#nodes or #tets) x components, row-major
};
/// The fields written with a mesh.
struct MeshFields {
  std::vector<MeshField> node_fields;  ///< point data
  std::vector<MeshField> tet_fields;   ///< cell data
};

/// Volume mesh formats: Gmsh, TetGen, legacy VTK, VTK XML, MEDIT, Abaqus / CalculiX.
enum class MeshFormat { unknown, msh, tetgen, vtk, vtu, medit, inp };
/// By extension: .msh .node .ele .vtk .vtu .mesh .inp (case-insensitive); unknown otherwise.
MeshFormat mesh_format_from_path(const std::string& path);

/// Options of the mesh writers.
struct MeshWriteOptions {
  bool binary = false;    ///< msh / vtk / vtu: binary payload (vtu: base64 inline)
  bool compress = false;  ///< vtu only: zlib-compressed base64 arrays (vtkZLibDataCompressor; implies binary)
  MeshFields fields;      ///< written where the format can hold them (vtu, vtk)
};

/// Options of read_mesh.
struct ReadMeshOptions {
  /// Validate after parsing: inverted tets reoriented with a warning; any other problem (bad
  /// index, degenerate tet, NaN, overshared face) fails with the file name and ids. Off: the
  /// mesh is returned as parsed (for `shatter inspect`, which reports every problem itself).
  bool validate = true;
};
/// Read any supported volume format.
Result<MeshReadResult> read_mesh(const std::string& path, const ReadMeshOptions& options = {});
/// Write any supported volume format by extension, atomically. For TetGen, `path` may end in
/// .node or .ele; both files are written, and replaced together or not at all.
Result<void> write_mesh(const std::string& path, const TetMesh& mesh, const MeshWriteOptions& options = {});

// --- Per-format parsers (bytes in memory; `name` is used in error messages; not validated: read_mesh does that). ---
/// Gmsh .msh 2.2 / 4.1, ASCII or binary.
Result<MeshReadResult> parse_msh(std::string_view bytes, const std::string& name);
/// Legacy VTK .vtk (UNSTRUCTURED_GRID, 4.2 / 5.1), ASCII or binary.
Result<MeshReadResult> parse_vtk(std::string_view bytes, const std::string& name);
/// VTK XML .vtu: ASCII, inline base64 or appended (raw or base64), each uncompressed or zlib-compressed.
Result<MeshReadResult> parse_vtu(std::string_view bytes, const std::string& name);
/// MEDIT ASCII .mesh.
Result<MeshReadResult> parse_medit(std::string_view bytes, const std::string& name);
/// Abaqus / CalculiX .inp subset (*NODE, *ELEMENT, *NSET, *ELSET).
Result<MeshReadResult> parse_inp(std::string_view bytes, const std::string& name);
/// TetGen .node and .ele files together.
Result<MeshReadResult> parse_tetgen(std::string_view node_bytes, const std::string& node_name,
                                    std::string_view ele_bytes, const std::string& ele_name);

// --- Per-format writers (stream out; the caller makes it atomic). ---
/// Gmsh .msh 4.1, ASCII or binary (fields are not written).
Result<void> write_msh(std::ostream& out, const TetMesh& mesh, const MeshWriteOptions& options = {});
/// Legacy VTK 4.2, ASCII or binary, with ids, tags and the fields.
Result<void> write_vtk(std::ostream& out, const TetMesh& mesh, const MeshWriteOptions& options = {});
/// VTK XML .vtu, ASCII or inline base64 (zlib-compressed with options.compress), with ids, tags and the fields.
Result<void> write_vtu(std::ostream& out, const TetMesh& mesh, const MeshWriteOptions& options = {});
/// MEDIT ASCII .mesh.
Result<void> write_medit(std::ostream& out, const TetMesh& mesh);
/// Abaqus .inp: *NODE, *ELEMENT (C3D4) and the named sets as *NSET / *ELSET.
Result<void> write_inp(std::ostream& out, const TetMesh& mesh);
/// TetGen .node (node ids; node tags as boundary markers).
Result<void> write_tetgen_node(std::ostream& out, const TetMesh& mesh);
/// TetGen .ele (tet ids; tet tags as an attribute).
Result<void> write_tetgen_ele(std::ostream& out, const TetMesh& mesh);

/// A ParaView collection (.pvd) of time steps; rewritten atomically at every add() so a run that
/// stops still leaves a valid series.
class PvdSeries {
 public:
  /// A series written to `pvd_path` (nothing is written before the first add()).
  explicit PvdSeries(std::string pvd_path) : path_(std::move(pvd_path)) {}
  /// Record `file` (relative to the .pvd's folder) at `time` and rewrite the .pvd.
  Result<void> add(double time, const std::string& file);
  /// The .pvd file's path.
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::vector<std::pair<double, std::string>> entries_;
};

// --- Triangle surfaces. ---
/// Triangle surface formats.
enum class SurfaceFormat { unknown, obj, ply, stl };
/// By extension: .obj .ply .stl (case-insensitive); unknown otherwise.
SurfaceFormat surface_format_from_path(const std::string& path);

/// Options of the surface writers.
struct SurfaceWriteOptions {
  bool binary = false;  ///< ply / stl: binary (little-endian) instead of ASCII
  /// File id of each vertex (e.g. the tet-mesh node id), written where the format can hold it
  /// (PLY property `id`; an OBJ comment). Empty: none.
  std::vector<FileId> vertex_ids;
  /// Named integer values per triangle (e.g. "body", "crack"), written as PLY face properties;
  /// the other formats leave them out. Each must have one value per triangle.
  std::vector<std::pair<std::string, std::vector<std::int32_t>>> face_values;
};
/// Write any supported surface format by extension, atomically.
Result<void> write_surface(const std::string& path, const TriSurface& surface, const SurfaceWriteOptions& options = {});
/// Wavefront OBJ (v / f lines; vertex ids as comments).
Result<void> write_obj(std::ostream& out, const TriSurface& surface, const SurfaceWriteOptions& options = {});
/// PLY, ASCII or binary little-endian (vertex ids as property `id`, face values as int face
/// properties).
Result<void> write_ply(std::ostream& out, const TriSurface& surface, const SurfaceWriteOptions& options = {});
/// STL, ASCII or binary (vertex ids are not written).
Result<void> write_stl(std::ostream& out, const TriSurface& surface, const SurfaceWriteOptions& options = {});

/// A triangle surface as read (positions + triangles; vertex_node / triangle_tet left empty).
struct SurfaceReadResult {
  TriSurface surface;                ///< positions (m) and triangles
  std::vector<FileId> vertex_ids;    ///< from PLY `id` property, else empty
  std::string format;                ///< "obj", "ply ascii", "stl binary", ...
  std::vector<std::string> skipped;  ///< e.g. "3 lines", "polygons triangulated: 12"
};
/// OBJ (v/f; polygons fan-triangulated; negative indices), PLY (ASCII / binary LE and BE),
/// STL (ASCII / binary; coincident vertices welded exactly).
Result<SurfaceReadResult> read_surface(const std::string& path);
/// OBJ from bytes in memory; `name` is used in error messages.
Result<SurfaceReadResult> parse_obj(std::string_view bytes, const std::string& name);
/// PLY from bytes in memory; `name` is used in error messages.
Result<SurfaceReadResult> parse_ply(std::string_view bytes, const std::string& name);
/// STL (ASCII or binary, told apart by content) from bytes in memory; `name` is used in error messages.
Result<SurfaceReadResult> parse_stl(std::string_view bytes, const std::string& name);

}  // namespace shatter
