// MEDIT ASCII .mesh (MeshVersionFormatted 1-4, Dimension 3): Vertices with references (node tags)
// and Tetrahedra with references (tet tags); other sections are skipped and counted.
#include <ostream>
#include <string>

#include "shatter/mesh/io/io_util.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/io/mesh_io_util.h"
#include "shatter/mesh/io/text_cursor.h"

namespace shatter {
namespace {

using io::TextCursor;

/// Numbers per row of the sections we skip (including the reference where there is one).
int skipped_row_size(std::string_view keyword) {
  struct Entry {
    const char* name;
    int size;
  };
  static constexpr Entry kTable[] = {
      {"Edges", 3},
      {"Triangles", 4},
      {"Quadrilaterals", 5},
      {"Prisms", 7},
      {"Pyramids", 6},
      {"Hexahedra", 9},
      {"Hexaedra", 9},
      {"Corners", 1},
      {"RequiredVertices", 1},
      {"Ridges", 1},
      {"RequiredEdges", 1},
      {"RequiredTriangles", 1},
      {"Normals", 3},
      {"Tangents", 3},
      {"NormalAtVertices", 2},
      {"TangentAtVertices", 2},
      {"NormalAtTriangleVertices", 3},
      {"SubDomainFromMesh", 4},
      {"VertexOnGeometricVertex", 2},
      {"VertexOnGeometricEdge", 3},
      {"EdgeOnGeometricEdge", 2},
      {"EdgesP2", 4},
      {"TrianglesP2", 7},
      {"TetrahedraP2", 11},
  };
  for (const Entry& e : kTable)
    if (keyword == e.name) return e.size;
  return 0;
}

bool is_keyword(std::string_view t) {
  return !t.empty() && ((t[0] >= 'A' && t[0] <= 'Z') || (t[0] >= 'a' && t[0] <= 'z'));
}

Result<std::int64_t> section_count(TextCursor& c, std::string_view keyword, std::int64_t row_size) {
  c.skip_space('#');
  const std::int64_t line = c.line();
  SHATTER_TRY(n, c.next_int_in("section size", 0, io::kMaxEntities, '#'));
  const std::int64_t room = (static_cast<std::int64_t>(c.remaining()) + 1) / (2 * row_size);
  if (*n > room)
    return c.error_at(line, std::string(keyword) + " count " + std::to_string(*n) + " is larger than the " +
                                std::to_string(c.remaining()) + " bytes that follow can hold");
  return n;
}

}  // namespace

Result<MeshReadResult> parse_medit(std::string_view bytes, const std::string& name) {
  MeshReadResult result;
  TetMesh& mesh = result.mesh;
  TextCursor c(bytes, name);
  constexpr char kComment = '#';

  const std::string_view first = c.peek_token(kComment);
  if (first.empty()) return c.error("empty file: expected 'MeshVersionFormatted'");
  SHATTER_TRY(head, c.expect("MeshVersionFormatted", false, kComment));
  SHATTER_TRY(version, c.next_int_in("MeshVersionFormatted version", 1, 4, kComment));
  result.format = "medit " + std::to_string(*version) + " ascii";

  bool have_dimension = false, have_vertices = false;
  std::int64_t end_line = -1;
  std::vector<std::string> skipped_keywords;
  while (true) {
    c.skip_space(kComment);
    const std::int64_t line = c.line();
    const std::string_view kw = c.next_token(kComment);
    if (kw.empty()) break;
    if (kw == "End") {
      end_line = line;
      break;
    }
    if (!is_keyword(kw)) return c.error_at(line, "expected a keyword, found " + io::quote_token(kw));
    if (kw == "Dimension") {
      SHATTER_TRY(d, c.next_int("dimension", kComment));
      if (*d != 3) return c.error("only 3D meshes can be read: expected 'Dimension 3', found " + std::to_string(*d));
      have_dimension = true;
    } else if (kw == "Vertices") {
      if (!have_dimension) return c.error_at(line, "'Vertices' before 'Dimension 3'");
      if (have_vertices) return c.error_at(line, "a second 'Vertices' section");
      have_vertices = true;
      SHATTER_TRY(n, section_count(c, kw, 4));
      mesh.positions.reserve(static_cast<std::size_t>(*n));
      mesh.node_tags.reserve(static_cast<std::size_t>(*n));
      for (std::int64_t i = 0; i < *n; ++i) {
        Vec3 p;
        for (int k = 0; k < 3; ++k) {
          SHATTER_TRY(x, c.next_double("vertex coordinate", kComment));
          p[k] = *x;
        }
        SHATTER_TRY(ref, c.next_int_in("vertex reference", std::numeric_limits<std::int32_t>::min(),
                                       std::numeric_limits<std::int32_t>::max(), kComment));
        mesh.positions.push_back(p);
        mesh.node_tags.push_back(static_cast<std::int32_t>(*ref));
      }
    } else if (kw == "Tetrahedra") {
      if (!have_vertices) return c.error_at(line, "'Tetrahedra' before 'Vertices'");
      SHATTER_TRY(m, section_count(c, kw, 5));
      if (mesh.tets.size() + static_cast<std::size_t>(*m) > static_cast<std::size_t>(io::kMaxEntities))
        return c.error_at(line, "too many tetrahedra");
      mesh.tets.reserve(mesh.tets.size() + static_cast<std::size_t>(*m));
      mesh.tet_tags.reserve(mesh.tets.size() + static_cast<std::size_t>(*m));
      for (std::int64_t e = 0; e < *m; ++e) {
        TetIndices t{};
        for (int k = 0; k < 4; ++k) {
          SHATTER_TRY(v, c.next_int_in("vertex index", 1, mesh.num_nodes(), kComment));
          t[k] = static_cast<Index>(*v - 1);
        }
        SHATTER_TRY(ref, c.next_int_in("tetrahedron reference", std::numeric_limits<std::int32_t>::min(),
                                       std::numeric_limits<std::int32_t>::max(), kComment));
        mesh.tets.push_back(t);
        mesh.tet_tags.push_back(static_cast<std::int32_t>(*ref));
      }
    } else if (kw == "Identifier" || kw == "Geometry") {
      c.skip_line();
      c.skip_space(kComment);
      c.skip_line();
    } else if (const int size = skipped_row_size(kw); size > 0) {
      SHATTER_TRY(n, section_count(c, kw, size));
      for (std::int64_t i = 0; i < *n * size; ++i) {
        SHATTER_TRY(x, c.next_double("number", kComment));
        (void)x;
      }
      result.skipped.push_back(std::to_string(*n) + " " + std::string(kw));
    } else {
      // Unknown section: skip its numbers up to the next keyword.
      while (true) {
        const std::string_view t = c.peek_token(kComment);
        if (t.empty() || is_keyword(t)) break;
        (void)c.next_token(kComment);
      }
      result.skipped.push_back("section " + io::quote_token(kw));
    }
  }
  const std::int64_t last = end_line > 0 ? end_line : c.line();
  if (!have_vertices) return c.error_at(last, "file ends without a 'Vertices' section");
  if (mesh.tets.empty()) return c.error_at(last, "file ends without tetrahedra");
  io::drop_zero_tags(mesh.node_tags);
  io::drop_zero_tags(mesh.tet_tags);
  return result;
}

Result<void> write_medit(std::ostream& out, const TetMesh& mesh) {
  io::WriteBuffer buffer(out);
  std::string& s = buffer.text();
  s = "MeshVersionFormatted 2\nDimension 3\n\nVertices\n";
  s += std::to_string(mesh.num_nodes()) + "\n";
  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    for (int k = 0; k < 3; ++k) {
      io::append_double(s, mesh.positions[i][k]);
      s += ' ';
    }
    io::append_int(s, mesh.node_tags.empty() ? 0 : mesh.node_tags[i]);
    s += '\n';
    buffer.maybe_flush();
  }
  s += "\nTetrahedra\n" + std::to_string(mesh.num_tets()) + "\n";
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    for (int k = 0; k < 4; ++k) {
      io::append_int(s, mesh.tets[e][k] + 1);
      s += ' ';
    }
    io::append_int(s, mesh.tet_tags.empty() ? 0 : mesh.tet_tags[e]);
    s += '\n';
    buffer.maybe_flush();
  }
  s += "\nEnd\n";
  buffer.flush();
  return {};
}

}  // namespace shatter
