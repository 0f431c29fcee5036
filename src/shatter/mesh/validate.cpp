#include "shatter/mesh/validate.h"

#include <cmath>
#include <sstream>

#include "shatter/core/log.h"
#include "shatter/mesh/topology.h"

namespace shatter {

const char* to_string(MeshProblemKind kind) {
  switch (kind) {
    case MeshProblemKind::node_not_finite: return "node_not_finite";
    case MeshProblemKind::index_out_of_range: return "index_out_of_range";
    case MeshProblemKind::repeated_node: return "repeated_node";
    case MeshProblemKind::degenerate_tet: return "degenerate_tet";
    case MeshProblemKind::inverted_tet: return "inverted_tet";
    case MeshProblemKind::overshared_face: return "overshared_face";
    case MeshProblemKind::unreferenced_node: return "unreferenced_node";
    case MeshProblemKind::attribute_size: return "attribute_size";
  }
  return "unknown";
}

bool ValidationReport::has_errors() const {
  for (const MeshProblem& p : problems)
    if (p.severity == Severity::error) return true;
  return false;
}
std::size_t ValidationReport::count(MeshProblemKind kind) const {
  return counts.empty() ? 0 : counts[static_cast<std::size_t>(kind)];
}

namespace {
constexpr int kNumKinds = 8;

struct Collector {
  ValidationReport& report;
  int cap;
  void add(MeshProblemKind kind, Severity severity, const std::string& message) {
    auto& n = report.counts[static_cast<std::size_t>(kind)];
    if (n < static_cast<std::size_t>(cap)) report.problems.push_back({kind, severity, message});
    ++n;
  }
};

std::string describe_tet(const TetMesh& mesh, Index e) {
  std::ostringstream s;
  s << "tet " << mesh.tet_id(e) << " (nodes";
  for (Index v : mesh.tets[e]) {
    if (v >= 0 && v < mesh.num_nodes())
      s << ' ' << mesh.node_id(v);
    else
      s << " <index " << v << '>';
  }
  s << ')';
  return s.str();
}
}  // namespace

ValidationReport validate_mesh(const TetMesh& mesh, const ValidateOptions& options) {
  ValidationReport report;
  report.counts.assign(kNumKinds, 0);
  Collector c{report, options.max_reports_per_kind};
  const Index nn = mesh.num_nodes();
  const Index nt = mesh.num_tets();
  auto check_size = [&](std::size_t size, std::size_t expected, const char* name) {
    if (size != 0 && size != expected)
      c.add(MeshProblemKind::attribute_size, Severity::error,
            std::string(name) + " has " + std::to_string(size) + " entries, expected " + std::to_string(expected));
  };
  check_size(mesh.node_ids.size(), mesh.positions.size(), "node_ids");
  check_size(mesh.node_tags.size(), mesh.positions.size(), "node_tags");
  check_size(mesh.tet_ids.size(), mesh.tets.size(), "tet_ids");
  check_size(mesh.tet_tags.size(), mesh.tets.size(), "tet_tags");
  if (report.count(MeshProblemKind::attribute_size) > 0) return report;  // ids below would be wrong

  for (Index i = 0; i < nn; ++i)
    if (!mesh.positions[i].allFinite())
      c.add(MeshProblemKind::node_not_finite, Severity::error,
            "node " + std::to_string(mesh.node_id(i)) + " has a NaN or infinite coordinate");

  std::vector<char> used(nn, 0);
  std::vector<char> tet_ok(nt, 1);
  for (Index e = 0; e < nt; ++e) {
    const TetIndices& t = mesh.tets[e];
    for (Index v : t)
      if (v < 0 || v >= nn) {
        c.add(MeshProblemKind::index_out_of_range, Severity::error,
              describe_tet(mesh, e) + " references node index " + std::to_string(v) + ", expected 0.." +
                  std::to_string(nn - 1));
        tet_ok[e] = 0;
        break;
      }
    if (!tet_ok[e]) continue;
    for (Index v : t) used[v] = 1;
    if (t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] || t[2] == t[3]) {
      c.add(MeshProblemKind::repeated_node, Severity::error, describe_tet(mesh, e) + " uses a node twice");
      tet_ok[e] = 0;
      continue;
    }
    const Mat34 x = mesh.corners(e);
    if (!x.allFinite()) {
      tet_ok[e] = 0;
      continue;
    }
    // The test is relative (volume against the mean edge cubed), so it is made on the tet moved to
    // corner 0 and scaled to unit size: coordinates near +-1e308 or 1e100 times a unit mesh no
    // longer overflow into inf - inf = nan. Halves first, so the differences cannot overflow.
    Mat34 y;
    for (int a = 0; a < 4; ++a) y.col(a) = 0.5 * x.col(a) - 0.5 * x.col(0);
    const double size = y.cwiseAbs().maxCoeff();
    if (size > 0) y /= size;
    double mean_edge = 0.0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) mean_edge += (y.col(a) - y.col(b)).norm() / 6.0;
    const double unit_v = signed_volume(y.col(0), y.col(1), y.col(2), y.col(3));
    const double unit_eps = options.relative_volume_epsilon * mean_edge * mean_edge * mean_edge;
    const double scale3 = 8.0 * size * size * size;  // back to m^3 for the messages (may be inf)
    const double v = unit_v * scale3, eps = unit_eps * scale3;
    if (!(std::abs(unit_v) > unit_eps)) {
      std::ostringstream s;
      s << describe_tet(mesh, e) << " has volume " << v << ", degenerate (|volume| <= " << eps << ')';
      c.add(MeshProblemKind::degenerate_tet, Severity::error, s.str());
      tet_ok[e] = 0;
    } else if (unit_v < 0) {
      std::ostringstream s;
      s << describe_tet(mesh, e) << " is inverted (volume " << v << ")";
      c.add(MeshProblemKind::inverted_tet, Severity::warning, s.str());
    }
  }
  for (Index i = 0; i < nn; ++i)
    if (!used[i])
      c.add(MeshProblemKind::unreferenced_node, Severity::warning,
            "node " + std::to_string(mesh.node_id(i)) + " is used by no tet");

  if (report.count(MeshProblemKind::index_out_of_range) == 0) {
    const TetFaces faces = compute_faces(mesh);
    for (const auto& [f, e] : faces.overshared) {
      const TriIndices& t = faces.faces[f];
      c.add(MeshProblemKind::overshared_face, Severity::error,
            "face (nodes " + std::to_string(mesh.node_id(t[0])) + ' ' + std::to_string(mesh.node_id(t[1])) + ' ' +
                std::to_string(mesh.node_id(t[2])) + ") is shared by more than two tets, among them tet " +
                std::to_string(mesh.tet_id(e)));
    }
  }
  return report;
}

Index fix_orientation(TetMesh& mesh) {
  Index n = 0;
  for (Index e = 0; e < mesh.num_tets(); ++e)
    if (signed_volume(mesh, e) < 0) {
      std::swap(mesh.tets[e][2], mesh.tets[e][3]);
      ++n;
    }
  return n;
}

Result<void> check_and_repair(TetMesh& mesh, const std::string& source_name, const ValidateOptions& options) {
  const ValidationReport report = validate_mesh(mesh, options);
  std::string errors;
  int shown = 0;
  std::size_t total = 0;
  for (const MeshProblem& p : report.problems)
    if (p.severity == Severity::error) {
      ++total;
      if (shown++ < 5) errors += (errors.empty() ? "" : "; ") + p.message;
    }
  if (total > 0) {
    std::size_t all = 0;
    for (int k = 0; k < kNumKinds; ++k)
      if (k != static_cast<int>(MeshProblemKind::inverted_tet) &&
          k != static_cast<int>(MeshProblemKind::unreferenced_node))
        all += report.counts[k];
    if (all > 5) errors += "; and " + std::to_string(all - 5) + " more";
    return file_error(source_name, "invalid mesh: " + errors);
  }
  const std::size_t inverted = report.count(MeshProblemKind::inverted_tet);
  if (inverted > 0) {
    fix_orientation(mesh);
    std::string first;
    for (const MeshProblem& p : report.problems)
      if (p.kind == MeshProblemKind::inverted_tet) {
        first = p.message;
        break;
      }
    log_warning(source_name + ": reoriented " + std::to_string(inverted) +
                " negatively oriented tet(s), first: " + first);
  }
  const std::size_t unused = report.count(MeshProblemKind::unreferenced_node);
  if (unused > 0) log_warning(source_name + ": " + std::to_string(unused) + " node(s) used by no tet");
  return {};
}

}  // namespace shatter
