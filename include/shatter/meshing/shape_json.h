// Shape descriptions in JSON: a small CSG tree of primitives, revolutions, extrusions and closed
// surfaces with transforms (format and examples: docs/meshing.md). Every error names the file and
// the JSON path of the bad value, e.g. "shape.children[2].radius".
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "shatter/core/error.h"
#include "shatter/mesh/topology.h"
#include "shatter/meshing/sdf.h"

namespace shatter {

/// A parsed shape file: the shape and its meshing hints.
struct ShapeFile {
  std::string name;              ///< "name", or "" if absent
  Sdf sdf;                       ///< the "shape" tree
  double edge_length = 0;        ///< "edge_length" (m) if given, else 0
  std::int64_t target_tets = 0;  ///< "tets" if given, else 0
  double grading = 0;            ///< "grading" (stuffing.h) if given, else 0
  bool sharpen = true;           ///< "sharpen" (stuffing.h) if given, else true
};

/// Loads a closed surface file for {"type": "surface", "file": ...}; the path is already resolved
/// against the JSON file's folder. Without a loader, surface nodes are an error.
using SurfaceLoader = std::function<Result<TriSurface>(const std::string& path)>;

/// Options of parse_shape_json.
struct ShapeJsonOptions {
  std::string base_dir;        ///< folder that relative "file" paths start from
  SurfaceLoader load_surface;  ///< loader for "surface" nodes (empty: they are an error)
};

/// Parse a shape file held in memory; `file_name` is used in error messages.
Result<ShapeFile> parse_shape_json(std::string_view text, const std::string& file_name,
                                   const ShapeJsonOptions& options = {});
/// Read and parse a shape file; relative surface paths start from its folder.
Result<ShapeFile> read_shape_json(const std::string& path, SurfaceLoader load_surface = {});

}  // namespace shatter
