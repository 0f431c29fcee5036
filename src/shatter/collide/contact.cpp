// Hull-hull and hull-plane contact manifolds (see contact.h).
//
// Everything between two hulls is computed in the frame of one of them (B's vertices and normals
// are mapped into A's frame, or the reverse for B's faces), so no hull is transformed as a whole;
// only the final points and normal go to the world.
#include "shatter/collide/contact.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace shatter {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Axis preferences (Gregorius 2013; Box2D/Box3D use the same shape). A face of B replaces the face
// of A, and an edge pair replaces the faces, only when it separates the hulls clearly more:
// by kRelFace (kRelEdge) of the separation's magnitude plus an absolute tolerance of kAbs times
// the smaller hull radius. Boxes resting on boxes therefore always get a face manifold, and the
// choice does not flip between nearly equal axes from one step to the next.
constexpr double kRelFace = 0.02;
constexpr double kRelEdge = 0.1;
constexpr double kAbs = 0.002;
// Incident vertices up to this fraction of the smaller hull radius outside a side plane of the
// reference face are kept as they are (points clipped off lie on the side planes themselves).
// Corners of equal stacked boxes lie on the side planes; without the margin round-off would clip
// them now and keep them next step, and their feature ids would change.
constexpr double kSideMargin = 0.001;
// Edge pairs whose directions make a sine below this are skipped: their axis is ill defined, and
// the face normals next to them give the same separation to within that sine.
constexpr double kParallelSine = 1e-5;

// Feature id layout (see ManifoldPoint::feature in contact.h).
constexpr std::uint32_t kKindFaceA = 0, kKindFaceB = 1, kKindEdge = 2, kKindPlane = 3;
constexpr std::uint8_t kSideLine = 64;  // line code bit: a side plane of the reference face

// r * v and r^T * v written out (Eigen's fixed-size products are not always inlined).
Vec3 rotate(const Mat3& r, const Vec3& v) { return r.col(0) * v.x() + r.col(1) * v.y() + r.col(2) * v.z(); }
Vec3 rotate_back(const Mat3& r, const Vec3& v) { return {r.col(0).dot(v), r.col(1).dot(v), r.col(2).dot(v)}; }

// Maps points of one hull's frame into another's: to-frame = r * from-frame + t.
struct Relative {
  Mat3 r;
  Vec3 t;
  [[nodiscard]] Vec3 apply(const Vec3& p) const { return rotate(r, p) + t; }
};

// Frame of `from` seen from the frame of `to`.
Relative relative(const Transform& to, const Transform& from) {
  const Mat3 rt = to.rotation.transpose();
  return {rt * from.rotation, rotate(rt, from.translation - to.translation)};
}

struct FaceQuery {
  double separation = -kInf;
  Index face = -1;
};

struct EdgeQuery {
  double separation = -kInf;
  Index edge_a = -1;         // half-edge of A
  Index edge_b = -1;         // half-edge of B
  Vec3 axis = Vec3::Zero();  // unit, A's frame, from A to B
};

// One vertex of the polygon being clipped: its position in the reference frame, the two lines it
// lies on (its feature) and the line of the polygon edge that leaves it. A line code is an
// incident-face edge position (0..63) or kSideLine + a reference-face side position.
struct ClipVertex {
  Vec3 p;
  std::uint8_t line_a, line_b;
  std::uint8_t out;
};

// An edge for the edge query: start and direction of its even half-edge, the faces on its left (u)
// and right (v).
struct EdgeData {
  Vec3 p, d;
  Index u, v;
};

// Buffers kept between calls (per thread), so that steady-state queries do not allocate.
struct Scratch {
  std::vector<Vec3> b_in_a;         // B's vertices in A's frame
  std::vector<Vec3> a_in_b;         // A's vertices in B's frame
  std::vector<Vec3> b_normals;      // B's face normals in A's frame
  std::vector<EdgeData> edges;      // A's edges
  std::vector<EdgeData> b_edges;    // B's edges in A's frame
  std::vector<int> sign_a, sign_b;  // see query_edges
  std::vector<ClipVertex> poly, clipped;
  std::vector<Index> face_vertices;  // the incident face's vertices
  std::vector<ManifoldPoint> candidates;
};

// Points deeper than the deepest by less than this fraction of the (smaller) hull radius touch;
// the manifold is chosen among them first (reduce_manifold_points).
constexpr double kTouchBand = 0.02;

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

// Separation of `other` (placed in `ref`'s frame by `rel`) from the plane of face f of `ref`.
double face_separation(const ConvexHull& ref, Index f, const ConvexHull& other, const Relative& rel) {
  const HullFace& face = ref.faces[static_cast<std::size_t>(f)];
  const Index v = other.support(-rotate_back(rel.r, face.normal));
  return face.normal.dot(rel.apply(other.vertices[static_cast<std::size_t>(v)])) - face.offset;
}

// Deepest face of `ref` against the points `other` (in ref's frame); stops at the first face that
// separates them by more than `stop`.
FaceQuery query_faces(const ConvexHull& ref, const std::vector<Vec3>& other, double stop) {
  FaceQuery q;
  for (std::size_t f = 0; f < ref.faces.size(); ++f) {
    const Vec3& n = ref.faces[f].normal;
    double lowest = kInf;
    for (const Vec3& v : other) lowest = std::min(lowest, n.dot(v));
    const double sep = lowest - ref.faces[f].offset;
    if (sep > q.separation) {
      q = {sep, static_cast<Index>(f)};
      if (sep > stop) break;
    }
  }
  return q;
}

int sign(double x) { return static_cast<int>(x > 0) - static_cast<int>(x < 0); }

// Edge pairs of A and B whose Gauss-map arcs cross (Gregorius 2013: then the two edges make a face
// of the Minkowski difference A - B); the separation along the cross product of their directions,
// oriented away from A's centroid. B's vertices and normals come in A's frame. Stops once a pair
// separates the hulls by more than `stop`.
//
// Arcs u-v (edge of A: left and right face normals) and c-d (edge of B, normals negated for A - B)
// cross when c, d lie on opposite sides of the plane of u, v; u, v on opposite sides of the plane
// of c, d; and the arcs lie on the same hemisphere: with the planes' normals v x u and d x c,
//   (c.(v x u)) (d.(v x u)) < 0,  (u.(d x c)) (v.(d x c)) < 0,  (c.(v x u)) (v.(d x c)) > 0.
// v x u and d x c are negative multiples of the half-edges' directions (left face first,
// counter-clockwise loops), the same sign for both, and only signs matter; so the test needs just
// the signs of every face normal of one hull along every edge of the other, computed once per
// query (F_B E_A + F_A E_B products instead of 4 E_A E_B).
EdgeQuery query_edges(const ConvexHull& a, const ConvexHull& b, const std::vector<Vec3>& b_vertices,
                      const std::vector<Vec3>& b_normals, double stop) {
  Scratch& s = scratch();
  const std::size_t na = a.edges.size() / 2, nb = b.edges.size() / 2;
  const std::size_t fa = a.faces.size(), fb = b.faces.size();
  s.edges.clear();
  for (std::size_t k = 0; k < na; ++k) {
    const HullHalfEdge& h = a.edges[2 * k];
    const Vec3& p = a.vertices[static_cast<std::size_t>(h.origin)];
    s.edges.push_back(
        {p, a.vertices[static_cast<std::size_t>(a.edges[2 * k + 1].origin)] - p, h.face, a.edges[2 * k + 1].face});
  }
  s.b_edges.clear();
  for (std::size_t j = 0; j < nb; ++j) {
    const Vec3& p = b_vertices[static_cast<std::size_t>(b.edges[2 * j].origin)];
    s.b_edges.push_back({p, b_vertices[static_cast<std::size_t>(b.edges[2 * j + 1].origin)] - p, b.edges[2 * j].face,
                         b.edges[2 * j + 1].face});
  }
  // sign_b[f * na + k]: B's face f along A's edge k; sign_a[j * fa + f]: A's face f along B's edge j.
  s.sign_b.resize(fb * na);
  for (std::size_t f = 0; f < fb; ++f)
    for (std::size_t k = 0; k < na; ++k) s.sign_b[f * na + k] = sign(b_normals[f].dot(s.edges[k].d));
  s.sign_a.resize(nb * fa);
  for (std::size_t j = 0; j < nb; ++j)
    for (std::size_t f = 0; f < fa; ++f) s.sign_a[j * fa + f] = sign(a.faces[f].normal.dot(s.b_edges[j].d));

  EdgeQuery q;
  for (std::size_t j = 0; j < nb; ++j) {
    const int* c_row = &s.sign_b[static_cast<std::size_t>(s.b_edges[j].u) * na];
    const int* d_row = &s.sign_b[static_cast<std::size_t>(s.b_edges[j].v) * na];
    const int* j_row = &s.sign_a[j * fa];
    const EdgeData& eb = s.b_edges[j];
    for (std::size_t k = 0; k < na; ++k) {
      // c.(v x u), d.(v x u) have the signs of B's normals along A's edge (c, d and v x u are
      // negated, both); u.(d x c), v.(d x c) the opposite signs of A's normals along B's edge
      // (d x c is negated): hence `< 0` in the last test.
      const int cba = c_row[k], dba = d_row[k];
      const int adc = j_row[s.edges[k].u], bdc = j_row[s.edges[k].v];
      // One branch (`&`, not `&&`): few pairs pass, so it predicts well.
      if (!((cba * dba < 0) & (adc * bdc < 0) & (cba * bdc < 0))) continue;
      const EdgeData& ea = s.edges[k];
      Vec3 n = ea.d.cross(eb.d);
      const double len = n.norm();
      if (!(len > kParallelSine * std::sqrt(ea.d.squaredNorm() * eb.d.squaredNorm()))) continue;
      n /= len;
      if (n.dot(ea.p - a.centroid) < 0) n = -n;
      const double sep = n.dot(eb.p - ea.p);
      if (sep > q.separation) {
        q = {sep, static_cast<Index>(2 * k), static_cast<Index>(2 * j), n};
        if (sep > stop) return q;
      }
    }
  }
  return q;
}

// The separating-axis queries, in order, each stopping once the hulls are known to be farther
// apart than `stop`.
struct Sat {
  Relative ba;  // B in A's frame
  Relative ab;  // A in B's frame
  FaceQuery face_a, face_b;
  EdgeQuery edge;
  [[nodiscard]] double separation() const { return std::max({face_a.separation, face_b.separation, edge.separation}); }
};

Sat run_sat(const ConvexHull& a, const Transform& ta, const ConvexHull& b, const Transform& tb, double stop) {
  Sat sat{relative(ta, tb), relative(tb, ta), {}, {}, {}};
  Scratch& s = scratch();
  s.b_in_a.clear();
  for (const Vec3& v : b.vertices) s.b_in_a.push_back(sat.ba.apply(v));
  sat.face_a = query_faces(a, s.b_in_a, stop);
  if (sat.face_a.separation > stop) return sat;
  s.a_in_b.clear();
  for (const Vec3& v : a.vertices) s.a_in_b.push_back(sat.ab.apply(v));
  sat.face_b = query_faces(b, s.a_in_b, stop);
  if (sat.face_b.separation > stop) return sat;
  s.b_normals.clear();
  for (const HullFace& f : b.faces) s.b_normals.push_back(rotate(sat.ba.r, f.normal));
  sat.edge = query_edges(a, b, s.b_in_a, s.b_normals, stop);
  return sat;
}

// The feature of the largest separation of a finished query, in SatCache form.
SatCache best_axis(const Sat& sat) {
  const double s = sat.separation();
  if (sat.face_a.face >= 0 && sat.face_a.separation == s) return {1, sat.face_a.face, -1};
  if (sat.face_b.face >= 0 && sat.face_b.separation == s) return {2, -1, sat.face_b.face};
  if (sat.edge.edge_a >= 0) return {3, sat.edge.edge_a, sat.edge.edge_b};
  return {};
}

// Separation along a cached axis, -inf when the cache does not fit these hulls. Any axis gives a
// lower bound of the distance, so a value above the speculative distance proves there is no contact.
double cached_separation(const SatCache& cache, const ConvexHull& a, const ConvexHull& b, const Relative& ba,
                         const Relative& ab) {
  switch (cache.kind) {
    case 1:
      if (cache.index_a < 0 || cache.index_a >= static_cast<Index>(a.faces.size())) return -kInf;
      return face_separation(a, cache.index_a, b, ba);
    case 2:
      if (cache.index_b < 0 || cache.index_b >= static_cast<Index>(b.faces.size())) return -kInf;
      return face_separation(b, cache.index_b, a, ab);
    case 3: {
      if (cache.index_a < 0 || cache.index_a >= static_cast<Index>(a.edges.size()) || cache.index_b < 0 ||
          cache.index_b >= static_cast<Index>(b.edges.size()))
        return -kInf;
      const Index ea = cache.index_a & ~1, eb = cache.index_b & ~1;
      const Vec3& pa = a.vertices[static_cast<std::size_t>(a.edges[static_cast<std::size_t>(ea)].origin)];
      const Vec3 da = a.vertices[static_cast<std::size_t>(a.edges[static_cast<std::size_t>(ea + 1)].origin)] - pa;
      const Vec3 pb = b.vertices[static_cast<std::size_t>(b.edges[static_cast<std::size_t>(eb)].origin)];
      const Vec3 db =
          rotate(ba.r, b.vertices[static_cast<std::size_t>(b.edges[static_cast<std::size_t>(eb + 1)].origin)] - pb);
      Vec3 n = da.cross(db);
      const double len = n.norm();
      if (!(len > kParallelSine * std::sqrt(da.squaredNorm() * db.squaredNorm()))) return -kInf;
      n /= len;
      // True separation along +n and -n (supports, not the edge points: the cached pair need not
      // be a Minkowski face now).
      const double lo_b_pos = n.dot(ba.apply(b.vertices[static_cast<std::size_t>(b.support(-(rotate_back(ba.r, n))))]));
      const double hi_b_pos = n.dot(ba.apply(b.vertices[static_cast<std::size_t>(b.support(rotate_back(ba.r, n)))]));
      const double hi_a = n.dot(a.vertices[static_cast<std::size_t>(a.support(n))]);
      const double lo_a = n.dot(a.vertices[static_cast<std::size_t>(a.support(-n))]);
      return std::max(lo_b_pos - hi_a, lo_a - hi_b_pos);
    }
    default: return -kInf;
  }
}

std::uint8_t line_code(std::uint8_t base, int position) { return static_cast<std::uint8_t>(base | (position & 63)); }

std::uint32_t face_feature(std::uint32_t kind, Index ref_face, Index inc_face, std::uint8_t l0, std::uint8_t l1) {
  const std::uint32_t lo = std::min(l0, l1), hi = std::max(l0, l1);
  return kind << 30 | (static_cast<std::uint32_t>(ref_face) & 255u) << 22 |
         (static_cast<std::uint32_t>(inc_face) & 255u) << 14 | lo << 7 | hi;
}

// Feature of an overlapping vertex of the incident hull off its incident face: the line codes
// (127, i mod 127) in that order (clipped points have the smaller code first, and (127, 127)
// marks the single deepest vertex), the incident-face field i / 127.
std::uint32_t overlap_feature(std::uint32_t kind, Index ref_face, Index i) {
  const auto v = static_cast<std::uint32_t>(i);
  return kind << 30 | (static_cast<std::uint32_t>(ref_face) & 255u) << 22 | ((v / 127) & 255u) << 14 | 127u << 7 |
         v % 127;
}

// The side plane through half-edge e of face rf of `ref`: outward unit normal and offset (points p
// with normal . p > offset lie outside). Counter-clockwise loop seen from outside: (v1 - v0) x n
// points out of the face.
struct SidePlane {
  Vec3 normal;
  double offset;
};
SidePlane side_plane(const ConvexHull& ref, const HullFace& rf, const HullHalfEdge& h) {
  const Vec3& v0 = ref.vertices[static_cast<std::size_t>(h.origin)];
  const Vec3& v1 = ref.vertices[static_cast<std::size_t>(ref.edges[static_cast<std::size_t>(h.next)].origin)];
  const Vec3 normal = (v1 - v0).cross(rf.normal).normalized();
  return {normal, normal.dot(v0)};
}

// Whether p (reference frame) lies within the side planes of reference face rf, moved out by margin.
bool within_sides(const ConvexHull& ref, const HullFace& rf, const Vec3& p, double margin) {
  const Index first = rf.edge;
  Index e = first;
  do {
    const HullHalfEdge& h = ref.edges[static_cast<std::size_t>(e)];
    const SidePlane side = side_plane(ref, rf, h);
    if (side.normal.dot(p) - side.offset > margin) return false;
    e = h.next;
  } while (e != first);
  return true;
}

// Face contact in the reference hull's frame: the incident face of `inc` (placed by `rel`) clipped
// against the side planes of face `ref_face` of `ref`. Writes the reduced points (reference frame)
// to `out` and returns their count.
int face_contact(const ConvexHull& ref, Index ref_face, const ConvexHull& inc, const Relative& rel,
                 double speculative_distance, double side_margin, std::uint32_t kind,
                 std::array<ManifoldPoint, 4>& out) {
  Scratch& s = scratch();
  const HullFace& rf = ref.faces[static_cast<std::size_t>(ref_face)];
  const Vec3& n = rf.normal;

  // Incident face: the face of `inc` most anti-parallel to the reference normal.
  const Vec3 n_inc = rotate_back(rel.r, n);
  Index inc_face = 0;
  double lowest = kInf;
  for (Index f = 0; f < static_cast<Index>(inc.faces.size()); ++f) {
    const double d = inc.faces[static_cast<std::size_t>(f)].normal.dot(n_inc);
    if (d < lowest) {
      lowest = d;
      inc_face = f;
    }
  }

  // Incident polygon in the reference frame; vertex i lies on incident edges i-1 and i.
  s.poly.clear();
  s.face_vertices.clear();
  {
    const Index first = inc.faces[static_cast<std::size_t>(inc_face)].edge;
    Index e = first;
    int count = 0;
    do {
      ++count;
      e = inc.edges[static_cast<std::size_t>(e)].next;
    } while (e != first);
    int i = 0;
    do {
      const HullHalfEdge& h = inc.edges[static_cast<std::size_t>(e)];
      s.poly.push_back({rel.apply(inc.vertices[static_cast<std::size_t>(h.origin)]),
                        line_code(0, (i + count - 1) % count), line_code(0, i), line_code(0, i)});
      s.face_vertices.push_back(h.origin);
      e = h.next;
      ++i;
    } while (e != first);
  }

  // Sutherland-Hodgman against each side plane of the reference face (moved out by side_margin).
  {
    const Index first = rf.edge;
    Index e = first;
    int side = 0;
    do {
      const HullHalfEdge& h = ref.edges[static_cast<std::size_t>(e)];
      const auto [plane, offset] = side_plane(ref, rf, h);
      const std::uint8_t code = line_code(kSideLine, side);
      s.clipped.clear();
      const std::size_t m = s.poly.size();
      for (std::size_t i = 0; i < m; ++i) {
        const ClipVertex& p = s.poly[i];
        const ClipVertex& q = s.poly[(i + 1) % m];
        const double dp = plane.dot(p.p) - offset, dq = plane.dot(q.p) - offset;
        const bool p_in = dp <= side_margin, q_in = dq <= side_margin;
        if (p_in) s.clipped.push_back(p);
        // A crossing adds a point on the plane itself, unless the inside end is kept within the
        // margin (then that end is the polygon's last point on this side).
        if (p_in != q_in && (p_in ? dp : dq) < 0) {
          const Vec3 x = p.p + (dp / (dp - dq)) * (q.p - p.p);
          // Leaving: the polygon goes on along this side plane; entering: along the line of p-q.
          s.clipped.push_back({x, p.out, code, p_in ? code : p.out});
        }
      }
      s.poly.swap(s.clipped);
      if (s.poly.empty()) break;
      e = h.next;
      ++side;
    } while (e != first);
  }

  // Points within the speculative distance, moved midway between the two surfaces.
  s.candidates.clear();
  for (const ClipVertex& v : s.poly) {
    const double sep = n.dot(v.p) - rf.offset;
    if (sep <= speculative_distance)
      s.candidates.push_back({v.p - 0.5 * sep * n, sep, face_feature(kind, ref_face, inc_face, v.line_a, v.line_b)});
  }
  // And every vertex of `inc` off the incident face that overlaps, within the side planes: a hull
  // sunk past its incident face (a curved shard pressed into a block) has overlapping corners off
  // that face, and a manifold of the face alone pushes on one side of it, turning it while its
  // other side stays in. (As collide_hull_plane does.)
  const double shift = n.dot(rel.t) - rf.offset;  // separation of inc's vertex v: n_inc . v + shift
  for (Index i = 0; i < static_cast<Index>(inc.vertices.size()); ++i) {
    if (n_inc.dot(inc.vertices[static_cast<std::size_t>(i)]) + shift >= 0 ||
        std::find(s.face_vertices.begin(), s.face_vertices.end(), i) != s.face_vertices.end())
      continue;
    const Vec3 p = rel.apply(inc.vertices[static_cast<std::size_t>(i)]);
    const double sep = n.dot(p) - rf.offset;
    if (sep < 0 && within_sides(ref, rf, p, side_margin))
      s.candidates.push_back({p - 0.5 * sep * n, sep, overlap_feature(kind, ref_face, i)});
  }
  return reduce_manifold_points(n, s.candidates, out, kTouchBand * std::min(ref.radius, inc.radius));
}

// Closest points c1 on segment p1 + s d1 and c2 on p2 + t d2, s, t in [0, 1] (Ericson,
// Real-Time Collision Detection, 5.1.9; the segments have positive length).
void closest_points_of_segments(const Vec3& p1, const Vec3& d1, const Vec3& p2, const Vec3& d2, Vec3& c1, Vec3& c2) {
  const Vec3 r = p1 - p2;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double c = d1.dot(r), b = d1.dot(d2);
  const double denom = a * e - b * b;
  double s = denom > 0 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0) {
    t = 0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1) {
    t = 1;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  c1 = p1 + s * d1;
  c2 = p2 + t * d2;
}

// Edge contact: one point midway between the closest points of the edge pair the query found;
// its separation is the query's (the gap along the axis).
void edge_contact(const ConvexHull& a, const Transform& ta, const ConvexHull& b, const Sat& sat, ContactManifold& m) {
  const EdgeQuery& q = sat.edge;
  const auto vertex_a = [&a](Index e) {
    return a.vertices[static_cast<std::size_t>(a.edges[static_cast<std::size_t>(e)].origin)];
  };
  const auto vertex_b = [&b, &sat](Index e) {
    return sat.ba.apply(b.vertices[static_cast<std::size_t>(b.edges[static_cast<std::size_t>(e)].origin)]);
  };
  const Vec3 pa = vertex_a(q.edge_a), pb = vertex_b(q.edge_b);
  Vec3 c1, c2;
  closest_points_of_segments(pa, vertex_a(q.edge_a + 1) - pa, pb, vertex_b(q.edge_b + 1) - pb, c1, c2);
  m.normal = ta.rotation * q.axis;
  m.points[0] = {ta.apply(0.5 * (c1 + c2)), q.separation,
                 kKindEdge << 30 | (static_cast<std::uint32_t>(q.edge_a >> 1) & 0x7fffu) << 15 |
                     (static_cast<std::uint32_t>(q.edge_b >> 1) & 0x7fffu)};
  m.count = 1;
}

double tolerance_scale(const ConvexHull& a, const ConvexHull& b) { return std::min(a.radius, b.radius); }

}  // namespace

double hull_separation(const ConvexHull& a, const Transform& ta, const ConvexHull& b, const Transform& tb,
                       SatCache* axis) {
  const Sat sat = run_sat(a, ta, b, tb, kInf);
  if (axis != nullptr) *axis = best_axis(sat);
  return sat.separation();
}

ContactManifold collide_hulls(const ConvexHull& a, const Transform& ta, const ConvexHull& b, const Transform& tb,
                              double speculative_distance, SatCache* cache) {
  ContactManifold m;
  if (cache != nullptr && cache->kind != 0) {
    const double s = cached_separation(*cache, a, b, relative(ta, tb), relative(tb, ta));
    if (s > speculative_distance) return m;  // still separated along the cached axis
  }
  const Sat sat = run_sat(a, ta, b, tb, speculative_distance);
  if (cache != nullptr) *cache = best_axis(sat);
  if (!(sat.separation() <= speculative_distance)) return m;

  const double scale = tolerance_scale(a, b);
  const double abs_tol = kAbs * scale;
  const double face_best = std::max(sat.face_a.separation, sat.face_b.separation);
  if (sat.edge.edge_a >= 0 && sat.edge.separation > face_best + kRelEdge * std::abs(face_best) + abs_tol) {
    edge_contact(a, ta, b, sat, m);
    return m;
  }

  const bool flip =
      sat.face_b.separation > sat.face_a.separation + kRelFace * std::abs(sat.face_a.separation) + abs_tol;
  const ConvexHull& ref = flip ? b : a;
  const ConvexHull& inc = flip ? a : b;
  const Transform& t_ref = flip ? tb : ta;
  const Relative& rel = flip ? sat.ab : sat.ba;
  const Index ref_face = flip ? sat.face_b.face : sat.face_a.face;
  const Vec3& n = ref.faces[static_cast<std::size_t>(ref_face)].normal;
  m.count = face_contact(ref, ref_face, inc, rel, speculative_distance, kSideMargin * scale,
                         flip ? kKindFaceB : kKindFaceA, m.points);
  if (m.count == 0) {
    // The incident face missed the reference face (deep or sideways overlaps, where the two
    // faces' axes are close): the edge pair if there is one, else the deepest incident vertex.
    if (sat.edge.edge_a >= 0 && sat.edge.separation <= speculative_distance) {
      edge_contact(a, ta, b, sat, m);
      return m;
    }
    const Vec3 v = rel.apply(inc.vertices[static_cast<std::size_t>(inc.support(-(rotate_back(rel.r, n))))]);
    const double sep = n.dot(v) - ref.faces[static_cast<std::size_t>(ref_face)].offset;
    m.points[0] = {v - 0.5 * sep * n, sep, face_feature(flip ? kKindFaceB : kKindFaceA, ref_face, 0, 127, 127)};
    m.count = 1;
  }
  m.normal = t_ref.rotation * n;
  if (flip) m.normal = -m.normal;
  for (int i = 0; i < m.count; ++i)
    m.points[static_cast<std::size_t>(i)].point = t_ref.apply(m.points[static_cast<std::size_t>(i)].point);
  return m;
}

ContactManifold collide_hull_plane(const ConvexHull& a, const Transform& ta, const Plane& plane,
                                   double speculative_distance, const HullMotion* motion) {
  // The plane in A's frame: n . x = offset.
  const Vec3 n = ta.rotation.transpose() * plane.normal;
  const double offset = plane.offset - plane.normal.dot(ta.translation);
  Scratch& s = scratch();
  s.candidates.clear();
  // As a face contact against the plane: the incident face is, of the faces around the deepest
  // vertex, the one most anti-parallel to the plane normal, and its corners within the speculative
  // distance are the points. Taking every vertex within reach instead gives a curved hull a support
  // polygon that jumps between distant vertices as it rolls, and the body rocks and gains energy.
  const Index deepest = a.support(-n);
  Index incident = -1;
  double most = -kInf;
  for (std::size_t e = 0; e < a.edges.size(); ++e) {
    if (a.edges[e].origin != deepest) continue;
    const Index f = a.edges[e].face;
    const double d = -a.faces[static_cast<std::size_t>(f)].normal.dot(n);
    if (d > most) {
      most = d;
      incident = f;
    }
  }
  const auto add_vertex = [&](Index i) {
    const Vec3& v = a.vertices[static_cast<std::size_t>(i)];
    const double sep = n.dot(v) - offset;
    if (sep <= speculative_distance)
      s.candidates.push_back(
          {v - 0.5 * sep * n, sep, kKindPlane << 30 | (static_cast<std::uint32_t>(i) & 0x3fffffffu)});
  };
  if (incident < 0) {
    add_vertex(deepest);
  } else {
    const Index first = a.faces[static_cast<std::size_t>(incident)].edge;
    Index e = first;
    do {
      add_vertex(a.edges[static_cast<std::size_t>(e)].origin);
      e = a.edges[static_cast<std::size_t>(e)].next;
    } while (e != first);
  }
  // And every other vertex that overlaps: a hull sunk deeper than its incident face (a thin shard
  // landing on an edge, a piece pressed in) has overlapping corners off that face, and a manifold
  // of the face alone pushes on one side of the body, turning it while its other side sinks.
  const std::size_t on_face = s.candidates.size();
  for (std::size_t i = 0; i < a.vertices.size(); ++i) {
    const double sep = n.dot(a.vertices[i]) - offset;
    if (sep >= 0) continue;
    const auto feature = kKindPlane << 30 | (static_cast<std::uint32_t>(i) & 0x3fffffffu);
    if (std::none_of(s.candidates.begin(), s.candidates.begin() + static_cast<std::ptrdiff_t>(on_face),
                     [feature](const ManifoldPoint& c) { return c.feature == feature; }))
      s.candidates.push_back({a.vertices[i] - 0.5 * sep * n, sep, feature});
  }
  ContactManifold m;
  m.normal = -plane.normal;
  // Reduced in A's frame; the normal's sign does not matter to the reduction's choice.
  m.count = reduce_manifold_points(-n, s.candidates, m.points, kTouchBand * a.radius);
  if (motion != nullptr && m.count > 0) {
    // The vertex the motion takes deepest: its separation at the step's end, held to first order,
    // sep - dt n . (v + w x r) with r = R v_i (the hull's frame turned into the world's).
    const Vec3 v = ta.rotation.transpose() * motion->linear_velocity;  // in A's frame
    const Vec3 w = ta.rotation.transpose() * motion->angular_velocity;
    // The landing's own turn: the impulse along n at the lowest vertex that stops its approach
    // (J = -v_n / (1/m + (r x n) . I^-1 (r x n))), and the motion it leaves.
    Vec3 landed_v = v, landed_w = w;
    bool lands = false;
    if (motion->inverse_mass > 0) {
      const Vec3& p0 = a.vertices[static_cast<std::size_t>(deepest)];
      const double vn = n.dot(v + w.cross(p0));
      const Vec3 rn = p0.cross(n);
      const Vec3 turn = motion->inverse_inertia * rn;
      const double k = motion->inverse_mass + rn.dot(turn);
      if (vn < 0 && k > 0) {
        const double j = -vn / k;
        landed_v = v + (j * motion->inverse_mass) * n;
        landed_w = w + j * turn;
        lands = true;
      }
    }
    // The vertex each motion takes deepest (deeper than motion->depth), among those within reach.
    const auto arriving = [&](const Vec3& lin, const Vec3& ang) {
      Index found = -1;
      double lowest = -motion->depth;
      for (std::size_t i = 0; i < a.vertices.size(); ++i) {
        const Vec3& p = a.vertices[i];
        const double sep = n.dot(p) - offset;
        const double end = sep + motion->dt * n.dot(lin + ang.cross(p));
        if (sep <= speculative_distance && end < lowest) {
          lowest = end;
          found = static_cast<Index>(i);
        }
      }
      return found;
    };
    // Held as a point (with its gap at the step's start) unless it is one already; in place of the
    // point with the widest gap when the manifold is full, never of `keep`.
    const auto hold = [&](Index vertex, int keep) {
      if (vertex < 0) return -1;
      const auto feature = kKindPlane << 30 | (static_cast<std::uint32_t>(vertex) & 0x3fffffffu);
      const auto held = m.points.begin() + m.count;
      if (std::any_of(m.points.begin(), held, [feature](const ManifoldPoint& c) { return c.feature == feature; }))
        return -1;
      int slot = m.count;
      if (m.count == 4) {
        slot = -1;
        for (int i = 0; i < 4; ++i)
          if (i != keep && (slot < 0 || m.points[static_cast<std::size_t>(i)].separation >
                                            m.points[static_cast<std::size_t>(slot)].separation))
            slot = i;
      } else {
        ++m.count;
      }
      const Vec3& p = a.vertices[static_cast<std::size_t>(vertex)];
      const double sep = n.dot(p) - offset;
      m.points[static_cast<std::size_t>(slot)] = {p - 0.5 * sep * n, sep, feature};
      return slot;
    };
    const int kept = hold(arriving(v, w), -1);
    if (lands) hold(arriving(landed_v, landed_w), kept);
  }
  for (int i = 0; i < m.count; ++i)
    m.points[static_cast<std::size_t>(i)].point = ta.apply(m.points[static_cast<std::size_t>(i)].point);
  return m;
}

int reduce_manifold_points(const Vec3& normal, std::span<const ManifoldPoint> candidates,
                           std::array<ManifoldPoint, 4>& out, double touch_band) {
  const std::size_t n = candidates.size();
  if (n <= 4) {
    std::copy(candidates.begin(), candidates.end(), out.begin());
    return static_cast<int>(n);
  }
  if (std::isfinite(touch_band)) {
    // Keep to the points that touch (overlapping, or within the band of the deepest) when they span
    // an area: a curved hull resting on a plane has many vertices within the speculative distance,
    // and a support polygon chosen from those with a gap lets the body sink and rock on the side
    // it leaves out.
    double deepest = kInf;
    for (const ManifoldPoint& c : candidates) deepest = std::min(deepest, c.separation);
    thread_local std::vector<ManifoldPoint> touching;
    touching.clear();
    for (const ManifoldPoint& c : candidates)
      if (c.separation <= std::max(deepest + touch_band, 0.0)) touching.push_back(c);
    if (touching.size() >= 3 && touching.size() < n) return reduce_manifold_points(normal, touching, out);
  }
  // 1: the deepest (lowest separation; ties to the first).
  std::size_t i0 = 0;
  for (std::size_t i = 1; i < n; ++i)
    if (candidates[i].separation < candidates[i0].separation) i0 = i;
  const Vec3& p0 = candidates[i0].point;
  // 2: the farthest from it across the normal.
  std::size_t i1 = i0;
  double best = -1;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 d = candidates[i].point - p0;
    const double dd = d.squaredNorm() - std::pow(d.dot(normal), 2);
    if (dd > best) {
      best = dd;
      i1 = i;
    }
  }
  const Vec3& p1 = candidates[i1].point;
  // Twice the signed area of triangle (p, q, r) seen along the normal.
  const auto area = [&normal](const Vec3& p, const Vec3& q, const Vec3& r) { return (q - p).cross(r - p).dot(normal); };
  // 3, 4: the largest triangles on each side of p0-p1.
  std::size_t i2 = i0, i3 = i0;
  double pos = 0, neg = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double s = area(p0, p1, candidates[i].point);
    if (s > pos) {
      pos = s;
      i2 = i;
    }
    if (s < neg) {
      neg = s;
      i3 = i;
    }
  }
  if (i2 == i0 && i3 == i0) {
    // All on the line p0-p1 (within round-off): the two ends are enough.
    out[0] = candidates[i0];
    out[1] = candidates[i1];
    return i1 == i0 ? 1 : 2;
  }
  if (i2 == i0 || i3 == i0) {
    // All on one side: the fourth point is the one that adds the most area to the triangle,
    // beyond the edge p0-t or t-p1 (t the third point), triangle oriented counter-clockwise.
    const bool left = i2 != i0;
    const std::size_t it = left ? i2 : i3;
    const Vec3& pt = candidates[it].point;
    const double sign = left ? 1.0 : -1.0;  // orients (p0, p1, pt) counter-clockwise
    std::size_t i4 = i0;
    double gain = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3& p = candidates[i].point;
      const double g = -std::min(sign * area(p1, pt, p), sign * area(pt, p0, p));
      if (g > gain) {
        gain = g;
        i4 = i;
      }
    }
    if (left)
      i3 = i4;
    else
      i2 = i4;
  }
  // Order around the polygon: p0, p3 (right side), p1, p2 (left side); a dropped duplicate (i0)
  // cannot remain here since one side was filled above or both were.
  int count = 0;
  for (const std::size_t i : {i0, i3, i1, i2})
    if (count == 0 || i != i0) out[static_cast<std::size_t>(count++)] = candidates[i];
  return count;
}

}  // namespace shatter
