// `shatter convert IN OUT`: any readable volume format to any writable one (by extension); an
// .obj / .ply / .stl output receives the boundary surface, with the volume mesh's node ids where
// the format can carry them.
#include <string>

#include "command.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/topology.h"

namespace shatter::cli {
namespace {

struct ConvertArgs {
  std::string input, output;
  bool binary = false;
  bool compress = false;
  bool quiet = false;
};

int run_convert(const ConvertArgs& args) {
  const bool to_surface = surface_format_from_path(args.output) != SurfaceFormat::unknown;
  if (!to_surface && mesh_format_from_path(args.output) == MeshFormat::unknown)
    return report_error(args.output +
                            ": unknown output extension; expected .msh .vtk .vtu .mesh .inp .node .ele "
                            "(volume) or .obj .ply .stl (boundary surface)",
                        kExitUsage);
  if (args.compress && mesh_format_from_path(args.output) != MeshFormat::vtu)
    return report_error(args.output + ": --compress applies to .vtu output only", kExitUsage);
  auto read = read_mesh(args.input);
  if (!read) return report_error(read.error().to_string(), kExitBadInput);
  for (const std::string& s : read->skipped)
    std::fprintf(stderr, "shatter: note: %s: skipped %s\n", args.input.c_str(), s.c_str());
  Result<void> written;
  if (to_surface) {
    const TriSurface surface = boundary_surface(read->mesh);
    SurfaceWriteOptions options{.binary = args.binary};
    for (Index node : surface.vertex_node) options.vertex_ids.push_back(read->mesh.node_id(node));
    written = write_surface(args.output, surface, options);
  } else {
    written = write_mesh(args.output, read->mesh, MeshWriteOptions{.binary = args.binary, .compress = args.compress});
  }
  if (!written) return report_error(written.error().to_string(), kExitOutput);
  if (!args.quiet)
    std::fprintf(stderr, "shatter: wrote %s (%d nodes, %d tets)\n", args.output.c_str(), read->mesh.num_nodes(),
                 read->mesh.num_tets());
  return kExitOk;
}

RunFn setup_convert(CLI::App& sub) {
  auto args = std::make_shared<ConvertArgs>();
  sub.add_option("IN", args->input, "Input mesh")->required();
  sub.add_option("OUT", args->output, "Output file; format by extension")->required();
  sub.add_flag("--binary", args->binary, "Binary payload where the format has one (msh, vtk, vtu, ply, stl)");
  sub.add_flag("--compress", args->compress, ".vtu: zlib-compressed arrays (vtkZLibDataCompressor; implies --binary)");
  sub.add_flag("-q,--quiet", args->quiet, "No message on success");
  return [args] { return run_convert(*args); };
}

const Registration convert_command{"convert", "Convert a mesh between formats (by extension)", &setup_convert};

}  // namespace
}  // namespace shatter::cli
