// Volume mesh reading and writing by file extension: read the bytes, parse, validate and repair;
// write through a temporary file so a failure never leaves half a mesh (TetGen's two files are
// replaced together).
#include "shatter/mesh/io/mesh_io.h"

#include <ostream>

#include "shatter/core/file_io.h"
#include "shatter/mesh/validate.h"

namespace shatter {
namespace {

/// "a/b.node" -> "a/b.ele" (keeping the case of the extension's first letter).
std::string tetgen_sibling(const std::string& path, bool want_ele) {
  const std::size_t dot = path.find_last_of('.');
  const bool upper = dot + 1 < path.size() && path[dot + 1] >= 'A' && path[dot + 1] <= 'Z';
  std::string ext = want_ele ? (upper ? ".ELE" : ".ele") : (upper ? ".NODE" : ".node");
  return path.substr(0, dot) + ext;
}

}  // namespace

MeshFormat mesh_format_from_path(const std::string& path) {
  const std::string ext = file_extension(path);
  if (ext == ".msh") return MeshFormat::msh;
  if (ext == ".node" || ext == ".ele") return MeshFormat::tetgen;
  if (ext == ".vtk") return MeshFormat::vtk;
  if (ext == ".vtu") return MeshFormat::vtu;
  if (ext == ".mesh") return MeshFormat::medit;
  if (ext == ".inp") return MeshFormat::inp;
  return MeshFormat::unknown;
}

Result<MeshReadResult> read_mesh(const std::string& path, const ReadMeshOptions& options) {
  const MeshFormat format = mesh_format_from_path(path);
  if (format == MeshFormat::unknown)
    return file_error(path, "unknown mesh format '" + file_extension(path) +
                                "': expected .msh, .node/.ele, .vtk, .vtu, .mesh or .inp");
  Result<MeshReadResult> parsed = file_error(path, "not read");
  if (format == MeshFormat::tetgen) {
    const bool is_ele = file_extension(path) == ".ele";
    const std::string node_path = is_ele ? tetgen_sibling(path, false) : path;
    const std::string ele_path = is_ele ? path : tetgen_sibling(path, true);
    SHATTER_TRY(node_bytes, read_file(node_path));
    SHATTER_TRY(ele_bytes, read_file(ele_path));
    parsed = parse_tetgen(*node_bytes, node_path, *ele_bytes, ele_path);
  } else {
    SHATTER_TRY(bytes, read_file(path));
    switch (format) {
      case MeshFormat::msh: parsed = parse_msh(*bytes, path); break;
      case MeshFormat::vtk: parsed = parse_vtk(*bytes, path); break;
      case MeshFormat::vtu: parsed = parse_vtu(*bytes, path); break;
      case MeshFormat::medit: parsed = parse_medit(*bytes, path); break;
      default: parsed = parse_inp(*bytes, path); break;
    }
  }
  if (!parsed.ok() || !options.validate) return parsed;
  SHATTER_TRY(valid, check_and_repair(parsed->mesh, path));
  return parsed;
}

Result<void> write_mesh(const std::string& path, const TetMesh& mesh, const MeshWriteOptions& options) {
  const MeshFormat format = mesh_format_from_path(path);
  switch (format) {
    case MeshFormat::unknown:
      return file_error(path, "unknown mesh format '" + file_extension(path) +
                                  "': expected .msh, .node/.ele, .vtk, .vtu, .mesh or .inp");
    case MeshFormat::tetgen: {
      const bool is_ele = file_extension(path) == ".ele";
      const std::string node_path = is_ele ? tetgen_sibling(path, false) : path;
      const std::string ele_path = is_ele ? path : tetgen_sibling(path, true);
      // Both files or neither: a new .node beside an old .ele would be a different mesh.
      OutputBatch batch;
      SHATTER_TRY(a, write_file_atomic(node_path, [&](std::ostream& out) { return write_tetgen_node(out, mesh); }));
      SHATTER_TRY(b, write_file_atomic(ele_path, [&](std::ostream& out) { return write_tetgen_ele(out, mesh); }));
      return batch.commit();
    }
    case MeshFormat::msh:
      return write_file_atomic(path, [&](std::ostream& out) { return write_msh(out, mesh, options); });
    case MeshFormat::vtk:
      return write_file_atomic(path, [&](std::ostream& out) { return write_vtk(out, mesh, options); });
    case MeshFormat::vtu:
      return write_file_atomic(path, [&](std::ostream& out) { return write_vtu(out, mesh, options); });
    case MeshFormat::medit: return write_file_atomic(path, [&](std::ostream& out) { return write_medit(out, mesh); });
    case MeshFormat::inp: return write_file_atomic(path, [&](std::ostream& out) { return write_inp(out, mesh); });
  }
  return file_error(path, "unknown mesh format");
}

}  // namespace shatter
