// TetGen .node / .ele: read (0- or 1-based, attributes, boundary markers, '#' comments, 4- or
// 10-node tets) and write (ids, node markers and tet region tags kept).
#include <cmath>
#include <ostream>
#include <string>

#include "shatter/mesh/io/io_util.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/io/mesh_io_util.h"
#include "shatter/mesh/io/text_cursor.h"

namespace shatter {
namespace {

using io::TextCursor;

/// One line with content: '#' comments stripped, split at blanks.
struct Row {
  std::int64_t line = 0;
  std::vector<std::string_view> tokens;
};

bool next_row(TextCursor& c, Row& row) {
  while (!c.at_end()) {
    row.line = c.line();
    std::string_view l = c.next_line();
    if (const auto h = l.find('#'); h != std::string_view::npos) l = l.substr(0, h);
    row.tokens.clear();
    std::size_t i = 0;
    while (i < l.size()) {
      while (i < l.size() && (l[i] == ' ' || l[i] == '\t' || l[i] == '\r' || l[i] == ',')) ++i;
      const std::size_t s = i;
      while (i < l.size() && !(l[i] == ' ' || l[i] == '\t' || l[i] == '\r' || l[i] == ',')) ++i;
      if (i > s) row.tokens.push_back(l.substr(s, i - s));
    }
    if (!row.tokens.empty()) return true;
  }
  return false;
}

Result<std::int64_t> row_int(const TextCursor& c, const Row& row, std::size_t k, const char* what, std::int64_t lo,
                             std::int64_t hi) {
  if (k >= row.tokens.size())
    return c.error_at(row.line, std::string("line ends where ") + what + " (an integer) was expected");
  std::int64_t v = 0;
  if (!io::parse_int(row.tokens[k], v))
    return c.error_at(row.line,
                      std::string("expected ") + what + " (an integer), found " + io::quote_token(row.tokens[k]));
  if (v < lo || v > hi)
    return c.error_at(row.line, std::string("expected ") + what + " in [" + std::to_string(lo) + ", " +
                                    std::to_string(hi) + "], found " + std::to_string(v));
  return v;
}

Result<double> row_double(const TextCursor& c, const Row& row, std::size_t k, const char* what) {
  if (k >= row.tokens.size())
    return c.error_at(row.line, std::string("line ends where ") + what + " (a number) was expected");
  double v = 0;
  if (!io::parse_double(row.tokens[k], v))
    return c.error_at(row.line,
                      std::string("expected ") + what + " (a finite number), found " + io::quote_token(row.tokens[k]));
  return v;
}

/// Rows of `tokens` each need at least 2 bytes per token (value + separator), except the last byte.
Result<void> check_rows_fit(const TextCursor& c, std::int64_t line, std::int64_t rows, std::int64_t tokens,
                            const char* what) {
  const std::int64_t room = (static_cast<std::int64_t>(c.remaining()) + 1) / (2 * tokens);
  if (rows > room)
    return c.error_at(line, std::string(what) + " count " + std::to_string(rows) + " is larger than the " +
                                std::to_string(c.remaining()) + " bytes that follow can hold");
  return {};
}

}  // namespace

Result<MeshReadResult> parse_tetgen(std::string_view node_bytes, const std::string& node_name,
                                    std::string_view ele_bytes, const std::string& ele_name) {
  MeshReadResult result;
  result.format = "tetgen";
  TetMesh& mesh = result.mesh;
  Row row;

  // .node: <#points> <dimension 3> <#attributes> <boundary markers 0|1>
  TextCursor nc(node_bytes, node_name);
  if (!next_row(nc, row)) return nc.error("empty file: expected '<#points> 3 <#attributes> <0|1>'");
  SHATTER_TRY(num_nodes, row_int(nc, row, 0, "point count", 0, io::kMaxEntities));
  if (row.tokens.size() > 1) {
    SHATTER_TRY(d, row_int(nc, row, 1, "dimension", 3, 3));
    (void)d;
  }
  std::int64_t num_node_attr = 0, num_node_markers = 0;
  if (row.tokens.size() > 2) {
    SHATTER_TRY(a, row_int(nc, row, 2, "attribute count", 0, static_cast<std::int64_t>(nc.remaining() / 2)));
    num_node_attr = *a;
  }
  if (row.tokens.size() > 3) {
    SHATTER_TRY(m, row_int(nc, row, 3, "boundary marker flag", 0, 1));
    num_node_markers = *m;
  }
  if (*num_nodes == 0) return nc.error_at(row.line, "point count is 0: a mesh needs points");
  SHATTER_TRY(fit, check_rows_fit(nc, row.line, *num_nodes, 4 + num_node_attr + num_node_markers, "point"));
  const auto n = static_cast<std::size_t>(*num_nodes);
  mesh.positions.reserve(n);
  mesh.node_ids.reserve(n);
  if (num_node_markers) mesh.node_tags.reserve(n);
  io::IdIndex node_index;
  node_index.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!next_row(nc, row))
      return nc.error("file ends after " + std::to_string(i) + " of " + std::to_string(n) + " points");
    SHATTER_TRY(id, row_int(nc, row, 0, "point number", std::numeric_limits<std::int64_t>::min(),
                            std::numeric_limits<std::int64_t>::max()));
    Vec3 p;
    for (int k = 0; k < 3; ++k) {
      SHATTER_TRY(x, row_double(nc, row, 1 + k, "coordinate"));
      p[k] = *x;
    }
    for (std::int64_t a = 0; a < num_node_attr; ++a) {
      SHATTER_TRY(x, row_double(nc, row, static_cast<std::size_t>(4 + a), "point attribute"));
      (void)x;
    }
    if (num_node_markers) {
      SHATTER_TRY(m, row_int(nc, row, static_cast<std::size_t>(4 + num_node_attr), "boundary marker",
                             std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max()));
      mesh.node_tags.push_back(static_cast<std::int32_t>(*m));
    }
    if (row.tokens.size() > static_cast<std::size_t>(4 + num_node_attr + num_node_markers))
      return nc.error_at(row.line, "unexpected " + io::quote_token(row.tokens[4 + num_node_attr + num_node_markers]) +
                                       " after the point's " + std::to_string(4 + num_node_attr + num_node_markers) +
                                       " values");
    if (!node_index.insert(*id, static_cast<Index>(i)))
      return nc.error_at(row.line, "point number " + std::to_string(*id) + " is defined twice");
    mesh.positions.push_back(p);
    mesh.node_ids.push_back(*id);
  }
  if (next_row(nc, row))
    return nc.error_at(row.line, "unexpected " + io::quote_token(row.tokens[0]) + " after the " + std::to_string(n) +
                                     " points the header announced");
  if (num_node_attr) result.skipped.push_back(std::to_string(num_node_attr) + " point attribute(s) per point");

  // .ele: <#tets> <nodes per tet 4|10> <#region attributes>
  TextCursor ec(ele_bytes, ele_name);
  if (!next_row(ec, row)) return ec.error("empty file: expected '<#tetrahedra> <4|10> <#attributes>'");
  SHATTER_TRY(num_tets, row_int(ec, row, 0, "tetrahedron count", 0, io::kMaxEntities));
  std::int64_t per_tet = 4, num_tet_attr = 0;
  if (row.tokens.size() > 1) {
    SHATTER_TRY(k, row_int(ec, row, 1, "nodes per tetrahedron", 4, 10));
    if (*k != 4 && *k != 10)
      return ec.error_at(row.line, "expected nodes per tetrahedron 4 or 10, found " + std::to_string(*k));
    per_tet = *k;
  }
  if (row.tokens.size() > 2) {
    SHATTER_TRY(a, row_int(ec, row, 2, "attribute count", 0, static_cast<std::int64_t>(ec.remaining() / 2)));
    num_tet_attr = *a;
  }
  SHATTER_TRY(fit2, check_rows_fit(ec, row.line, *num_tets, 1 + per_tet + num_tet_attr, "tetrahedron"));
  const auto m = static_cast<std::size_t>(*num_tets);
  mesh.tets.reserve(m);
  mesh.tet_ids.reserve(m);
  if (num_tet_attr) mesh.tet_tags.reserve(m);
  std::vector<bool> corner(n, false), midside(n, false);
  for (std::size_t e = 0; e < m; ++e) {
    if (!next_row(ec, row))
      return ec.error("file ends after " + std::to_string(e) + " of " + std::to_string(m) + " tetrahedra");
    SHATTER_TRY(id, row_int(ec, row, 0, "tetrahedron number", std::numeric_limits<std::int64_t>::min(),
                            std::numeric_limits<std::int64_t>::max()));
    TetIndices t{};
    for (std::int64_t k = 0; k < per_tet; ++k) {
      SHATTER_TRY(v, row_int(ec, row, static_cast<std::size_t>(1 + k), "node number",
                             std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::max()));
      const auto idx = node_index.find(*v);
      if (!idx)
        return ec.error_at(row.line, "tetrahedron " + std::to_string(*id) + " uses point " + std::to_string(*v) +
                                         ", which " + node_name + " does not define");
      if (k < 4) {
        t[k] = *idx;
        corner[*idx] = true;
      } else {
        midside[*idx] = true;
      }
    }
    for (std::int64_t a = 0; a < num_tet_attr; ++a) {
      SHATTER_TRY(x, row_double(ec, row, static_cast<std::size_t>(1 + per_tet + a), "region attribute"));
      if (a == 0) {
        // Range first: converting an out-of-range double to an integer is undefined.
        if (*x < std::numeric_limits<std::int32_t>::min() || *x > std::numeric_limits<std::int32_t>::max() ||
            *x != std::trunc(*x))
          return ec.error_at(row.line, "expected the region attribute to be a 32-bit integer, found " +
                                           io::quote_token(row.tokens[1 + per_tet]));
        mesh.tet_tags.push_back(static_cast<std::int32_t>(*x));
      }
    }
    if (row.tokens.size() > static_cast<std::size_t>(1 + per_tet + num_tet_attr))
      return ec.error_at(row.line, "unexpected " + io::quote_token(row.tokens[1 + per_tet + num_tet_attr]) +
                                       " after the tetrahedron's " + std::to_string(1 + per_tet + num_tet_attr) +
                                       " values");
    mesh.tets.push_back(t);
    mesh.tet_ids.push_back(*id);
  }
  if (next_row(ec, row))
    return ec.error_at(row.line, "unexpected " + io::quote_token(row.tokens[0]) + " after the " + std::to_string(m) +
                                     " tetrahedra the header announced");
  if (num_tet_attr > 1)
    result.skipped.push_back(std::to_string(num_tet_attr - 1) + " extra region attribute(s) per tetrahedron");
  if (per_tet == 10) {
    // Keep the corners; drop the nodes only the quadratic tets used as mid-edge nodes.
    const std::size_t dropped = io::remove_midside_nodes(mesh, corner, midside);
    result.skipped.push_back(std::to_string(m) + " 10-node tetrahedra read as 4-node (" + std::to_string(dropped) +
                             " mid-edge nodes dropped)");
  }
  io::drop_default_ids(mesh.node_ids);
  io::drop_default_ids(mesh.tet_ids);
  return result;
}

Result<void> write_tetgen_node(std::ostream& out, const TetMesh& mesh) {
  const bool markers = !mesh.node_tags.empty();
  io::WriteBuffer buffer(out);
  std::string& s = buffer.text();
  s += std::to_string(mesh.num_nodes()) + " 3 0 " + (markers ? "1" : "0") + "\n";
  for (Index i = 0; i < mesh.num_nodes(); ++i) {
    io::append_int(s, mesh.node_id(i));
    for (int k = 0; k < 3; ++k) {
      s += ' ';
      io::append_double(s, mesh.positions[i][k]);
    }
    if (markers) {
      s += ' ';
      io::append_int(s, mesh.node_tags[i]);
    }
    s += '\n';
    buffer.maybe_flush();
  }
  buffer.flush();
  return {};
}

Result<void> write_tetgen_ele(std::ostream& out, const TetMesh& mesh) {
  const bool tags = !mesh.tet_tags.empty();
  io::WriteBuffer buffer(out);
  std::string& s = buffer.text();
  s += std::to_string(mesh.num_tets()) + " 4 " + (tags ? "1" : "0") + "\n";
  for (Index e = 0; e < mesh.num_tets(); ++e) {
    io::append_int(s, mesh.tet_id(e));
    for (int k = 0; k < 4; ++k) {
      s += ' ';
      io::append_int(s, mesh.node_id(mesh.tets[e][k]));
    }
    if (tags) {
      s += ' ';
      io::append_int(s, mesh.tet_tags[e]);
    }
    s += '\n';
    buffer.maybe_flush();
  }
  buffer.flush();
  return {};
}

}  // namespace shatter
