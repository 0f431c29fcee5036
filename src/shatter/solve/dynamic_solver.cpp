// Implicit-Euler FEM dynamics as the minimisation of the incremental potential (see
// dynamic_solver.h and docs/dynamics.md).
#include "shatter/solve/dynamic_solver.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "shatter/core/parallel.h"

namespace shatter {
namespace {

// Sliding displacement over a step below which friction is smoothed (f0 of Li et al. 2020, C^1):
// f0(y) = y^2 / (2 eps) for y < eps, y - eps / 2 beyond; f0'(y) = min(y / eps, 1).
double friction_f0(double y, double eps) { return y < eps ? y * y / (2 * eps) : y - eps / 2; }

// A node's contact with obstacle j (planes first, then convexes): how deep it is and the unit
// normal it is pushed out along; depth <= 0 when it is outside.
struct Touch {
  double depth = 0;
  Vec3 normal = Vec3::Zero();
};
Touch touch(const DynamicObstacles& o, std::size_t j, const Vec3& x) {
  if (j < o.planes.size()) {
    const ContactPlane& p = o.planes[j];
    return {p.offset - p.normal.dot(x), p.normal};
  }
  Touch t{std::numeric_limits<double>::infinity(), Vec3::Zero()};
  for (const HalfSpace& f : o.convexes[j - o.planes.size()].faces) {
    const double d = f.offset - f.normal.dot(x);
    if (d <= 0) return {0, Vec3::Zero()};  // outside this face: outside the convex
    if (d < t.depth) t = {d, f.normal};
  }
  return t;
}
std::size_t obstacle_count(const DynamicObstacles& o) { return o.planes.size() + o.convexes.size(); }
double obstacle_friction(const DynamicObstacles& o, std::size_t j) {
  return j < o.planes.size() ? o.planes[j].friction : o.convexes[j - o.planes.size()].friction;
}

Mat34 corners(const std::vector<Vec3>& x, const TetIndices& t) {
  Mat34 c;
  for (int k = 0; k < 4; ++k) c.col(k) = x[t[k]];
  return c;
}

// The potential's terms that do not change within a step (docs/dynamics.md).
struct StepData {
  double h = 0;
  std::vector<double> inertia;  // w_i = m_i (1/h^2 + alpha/h), kg/s^2
  std::vector<Vec3> target;     // x~_i = x_i + h v_i / (1 + alpha h), m
  std::vector<double> penalty;  // k_i, N/m
  std::vector<Vec3> start;      // x at the step's start, m
  // Lagged friction: per (node, obstacle) in contact at the start, the tangent plane's normal
  // there and mu * lambda (N).
  struct Friction {
    Index node;
    Index obstacle;
    Vec3 normal;
    double mu_lambda;
  };
  // The node's tangential move over the step, m.
  [[nodiscard]] Vec3 slip(const Friction& f, const std::vector<Vec3>& x) const {
    const Vec3 u = x[f.node] - start[f.node];
    return u - f.normal * f.normal.dot(u);
  }
  std::vector<Friction> friction;
  std::vector<Mat12> damping;  // beta/h K_e at the start (projected), per tet; empty when beta = 0
};

class Potential {
 public:
  Potential(const FemModel& model, const DynamicObstacles& obstacles, const DynamicSolverOptions& options,
            const StepData& data)
      : model_(model), obstacles_(obstacles), options_(options), d_(data) {}

  // E(x), J: every term but the elastic one in node order, then the elastic energy.
  double energy(const std::vector<Vec3>& x) const {
    double e = total_energy(model_, x);
    const double eps = options_.friction_speed * d_.h;
    for (Index i = 0; i < model_.num_nodes; ++i) {
      e += 0.5 * d_.inertia[i] * (x[i] - d_.target[i]).squaredNorm() - model_.node_mass[i] * options_.gravity.dot(x[i]);
      for (std::size_t j = 0; j < obstacle_count(obstacles_); ++j) {
        const double depth = touch(obstacles_, j, x[i]).depth;
        if (depth > 0) e += 0.5 * d_.penalty[i] * depth * depth;
      }
    }
    for (const auto& f : d_.friction) e += f.mu_lambda * friction_f0(d_.slip(f, x).norm(), eps);
    if (!d_.damping.empty())
      for (Index t = 0; t < model_.num_tets(); ++t) {
        const Mat34 du = corners(x, model_.tets[t]) - corners(d_.start, model_.tets[t]);
        const Eigen::Map<const Eigen::Matrix<double, 12, 1>> v(du.data());
        e += 0.5 * v.dot(d_.damping[t] * v);
      }
    return e;
  }

  // g = dE/dx, N (#nodes).
  void gradient(const std::vector<Vec3>& x, std::vector<Vec3>& g, ForceWorkspace& workspace) const {
    internal_forces(model_, x, g, workspace);
    for (Index i = 0; i < model_.num_nodes; ++i) {
      g[i] += d_.inertia[i] * (x[i] - d_.target[i]) - model_.node_mass[i] * options_.gravity;
      for (std::size_t j = 0; j < obstacle_count(obstacles_); ++j) g[i] -= contact_force(i, j, x);
    }
    for (const auto& f : d_.friction) g[f.node] -= friction_force(f, x);
    if (!d_.damping.empty())
      for (Index t = 0; t < model_.num_tets(); ++t) {
        const TetIndices& tet = model_.tets[t];
        const Mat34 du = corners(x, tet) - corners(d_.start, tet);
        const Eigen::Map<const Eigen::Matrix<double, 12, 1>> v(du.data());
        const Eigen::Matrix<double, 12, 1> gv = d_.damping[t] * v;
        for (int k = 0; k < 4; ++k) g[tet[k]] += gv.segment<3>(3 * k);
      }
  }

  // The force obstacle j puts on node i at x (the penalty's), N.
  Vec3 contact_force(Index i, std::size_t j, const std::vector<Vec3>& x) const {
    const Touch t = touch(obstacles_, j, x[i]);
    return t.depth > 0 ? Vec3(d_.penalty[i] * t.depth * t.normal) : Vec3::Zero();
  }
  // The friction force on f's node at x, N.
  Vec3 friction_force(const StepData::Friction& f, const std::vector<Vec3>& x) const {
    const double eps = options_.friction_speed * d_.h;
    const Vec3 u = d_.slip(f, x);
    const double y = u.norm();
    return y > 0 ? Vec3(-f.mu_lambda * std::min(y / eps, 1.0) / y * u) : Vec3::Zero();
  }

  // The Hessian (elastic part exact or projected) into `matrix`.
  void hessian(const std::vector<Vec3>& x, bool projected, BlockSparseMatrix& matrix) const {
    matrix.refill([&](Index t) {
      Mat12 k = element_stiffness(model_, t, corners(x, model_.tets[t]), projected);
      if (!d_.damping.empty()) k += d_.damping[t];
      return k;
    });
    const double eps = options_.friction_speed * d_.h;
    std::vector<Mat3> node_block(static_cast<std::size_t>(model_.num_nodes), Mat3::Zero());
    for (Index i = 0; i < model_.num_nodes; ++i) {
      node_block[i] = d_.inertia[i] * Mat3::Identity();
      for (std::size_t j = 0; j < obstacle_count(obstacles_); ++j) {
        const Touch t = touch(obstacles_, j, x[i]);
        if (t.depth > 0) node_block[i] += d_.penalty[i] * t.normal * t.normal.transpose();
      }
    }
    for (const auto& f : d_.friction) {
      const Mat3 tangent = Mat3::Identity() - f.normal * f.normal.transpose();
      const Vec3 u = d_.slip(f, x);
      const double y = u.norm();
      if (y < eps) {
        node_block[f.node] += f.mu_lambda / eps * tangent;
      } else {
        const Vec3 s = u / y;  // PSD part: the curvature across the sliding direction
        node_block[f.node] += f.mu_lambda / y * (tangent - s * s.transpose());
      }
    }
    double* values = matrix.values();
    const std::vector<Index>& node_of = matrix.node_of_active();
    for (Index a = 0; a < matrix.num_active(); ++a) {
      const Index k = matrix.diagonal_block(a);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) values[matrix.block_entry(a, k, r, c)] += node_block[node_of[a]](r, c);
    }
  }

 private:
  const FemModel& model_;
  const DynamicObstacles& obstacles_;
  const DynamicSolverOptions& options_;
  const StepData& d_;
};

Result<void> check(const FemModel& model, const DynamicObstacles& obstacles, const DynamicSolverOptions& o,
                   const DynamicState& state) {
  const auto n = static_cast<std::size_t>(model.num_nodes);
  if (state.x.size() != n || state.v.size() != n)
    return make_error("dynamic step: the state has " + std::to_string(state.x.size()) + " positions and " +
                      std::to_string(state.v.size()) + " velocities for a model of " + std::to_string(n) + " nodes");
  for (std::size_t i = 0; i < n; ++i)
    if (!state.x[i].allFinite() || !state.v[i].allFinite())
      return make_error("dynamic step: node " + std::to_string(i) + " has a non-finite position or velocity");
  if (!(o.time_step > 0) || !std::isfinite(o.time_step))
    return make_error("dynamic step: time_step must be positive and finite");
  if (!o.gravity.allFinite()) return make_error("dynamic step: gravity must be finite");
  if (!(o.mass_damping >= 0) || !(o.stiffness_damping >= 0) || !std::isfinite(o.mass_damping) ||
      !std::isfinite(o.stiffness_damping))
    return make_error("dynamic step: mass_damping and stiffness_damping must be finite and >= 0");
  if (!(o.contact_stiffness > 0) || !std::isfinite(o.contact_stiffness))
    return make_error("dynamic step: contact_stiffness must be positive and finite");
  if (!(o.friction_speed > 0) || !std::isfinite(o.friction_speed))
    return make_error("dynamic step: friction_speed must be positive and finite");
  if (o.max_newton_iterations < 1) return make_error("dynamic step: max_newton_iterations must be >= 1");
  if (!(o.velocity_tolerance > 0)) return make_error("dynamic step: velocity_tolerance must be positive");
  const auto unit = [](const Vec3& normal) { return normal.allFinite() && std::abs(normal.norm() - 1) <= 1e-9; };
  const auto friction_ok = [](double mu) { return mu >= 0 && std::isfinite(mu); };
  const auto& planes = obstacles.planes;
  for (std::size_t p = 0; p < planes.size(); ++p)
    if (!unit(planes[p].normal) || !std::isfinite(planes[p].offset) || !friction_ok(planes[p].friction))
      return make_error("dynamic step: plane " + std::to_string(p) +
                        " needs a unit normal, a finite offset and a finite friction >= 0");
  const auto& convexes = obstacles.convexes;
  for (std::size_t c = 0; c < convexes.size(); ++c) {
    bool ok = convexes[c].faces.size() >= 4 && friction_ok(convexes[c].friction);
    for (const HalfSpace& f : convexes[c].faces) ok = ok && unit(f.normal) && std::isfinite(f.offset);
    if (!ok)
      return make_error("dynamic step: convex " + std::to_string(c) +
                        " needs at least 4 faces with unit normals and finite offsets, and a finite friction >= 0");
  }
  return {};
}

}  // namespace

DynamicSolver::DynamicSolver(const DynamicSolverOptions& options) : options_(options), linear_(options.linear) {}

Result<DynamicStepReport> DynamicSolver::step(const FemModel& model, const DynamicObstacles& obstacles,
                                              DynamicState& state) {
  SHATTER_TRY(ok, check(model, obstacles, options_, state));
  const DynamicSolverOptions& o = options_;
  const Index n = model.num_nodes;
  if (matrix_.num_nodes() != n || pattern_tets_ != model.tets) {
    matrix_ = BlockSparseMatrix(n, model.tets, {});
    pattern_tets_ = model.tets;
  }
  StepData d;
  d.h = o.time_step;
  const double h = d.h, alpha = o.mass_damping;
  d.start = state.x;
  d.inertia.resize(static_cast<std::size_t>(n));
  d.target.resize(static_cast<std::size_t>(n));
  d.penalty.resize(static_cast<std::size_t>(n));
  for (Index i = 0; i < n; ++i) {
    const double m = model.node_mass[i];
    d.inertia[i] = m * (1 / (h * h) + alpha / h);
    d.target[i] = state.x[i] + h * state.v[i] / (1 + alpha * h);
    d.penalty[i] = o.contact_stiffness * m / (h * h);
    for (std::size_t j = 0; j < obstacle_count(obstacles); ++j) {
      const Touch t = touch(obstacles, j, state.x[i]);
      const double mu = obstacle_friction(obstacles, j);
      if (t.depth > 0 && mu > 0)
        d.friction.push_back({i, static_cast<Index>(j), t.normal, mu * d.penalty[i] * t.depth});
    }
  }
  if (o.stiffness_damping > 0) {
    d.damping.resize(static_cast<std::size_t>(model.num_tets()));
    parallel_for(0, model.num_tets(), [&](std::int64_t t) {
      d.damping[static_cast<std::size_t>(t)] =
          o.stiffness_damping / h *
          element_stiffness(model, static_cast<Index>(t), corners(state.x, model.tets[static_cast<std::size_t>(t)]),
                            true);
    });
  }
  const Potential potential(model, obstacles, o, d);

  // Nodes in no tet have no stiffness row: they fly freely (inertia and gravity only).
  std::vector<Vec3> x = state.x;
  for (Index i = 0; i < n; ++i)
    if (matrix_.active_of_node()[i] < 0) x[i] = d.target[i] + o.gravity / (1 / (h * h) + alpha / h);

  DynamicStepReport report;
  std::vector<Vec3> g(static_cast<std::size_t>(n)), trial(static_cast<std::size_t>(n));
  const Index dofs = matrix_.size();
  Eigen::VectorXd rhs(dofs), dx(dofs);
  const std::vector<Index>& node_of = matrix_.node_of_active();
  double e = potential.energy(x);
  for (int it = 0; it < o.max_newton_iterations; ++it) {
    report.newton_iterations = it + 1;
    potential.gradient(x, g, workspace_);
    for (Index a = 0; a < matrix_.num_active(); ++a) rhs.segment<3>(3 * a) = -g[node_of[a]];
    // The exact elastic stiffness first; the projected one where that is indefinite or gives no
    // descent (as the static solver's on-demand tangent).
    bool descent = false;
    for (const bool projected : {false, true}) {
      potential.hessian(x, projected, matrix_);
      const LinearSolveReport lr = linear_.solve(matrix_, rhs, dx);
      descent = lr.converged && !lr.indefinite && dx.allFinite() && rhs.dot(dx) > 0;
      if (descent) break;
    }
    if (!descent) {
      report.message = "no descent direction (the linear solve failed)";
      break;
    }
    double max_step = 0;
    for (Index a = 0; a < matrix_.num_active(); ++a) max_step = std::max(max_step, dx.segment<3>(3 * a).norm());
    // Backtracking (Armijo) on E; a change within round-off of the terms counts as no change.
    const double slope = -rhs.dot(dx);
    const double noise = 1e-12 * (std::abs(e) + 1e-300);
    double t = 1;
    bool accepted = false;
    for (int cut = 0; cut < 40; ++cut) {
      trial = x;
      for (Index a = 0; a < matrix_.num_active(); ++a) trial[node_of[a]] += t * dx.segment<3>(3 * a);
      const double et = potential.energy(trial);
      if (std::isfinite(et) && (et <= e + 1e-4 * t * slope || std::abs(et - e) <= noise)) {
        x.swap(trial);
        e = et;
        accepted = true;
        break;
      }
      t *= 0.5;
      ++report.line_search_cuts;
    }
    report.max_step = t * max_step;
    if (!accepted) {
      report.message = "the line search found no lower energy";
      break;
    }
    if (max_step <= o.velocity_tolerance * h) {
      report.converged = true;
      break;
    }
  }
  if (!report.converged && report.message.empty())
    report.message = "no convergence in " + std::to_string(o.max_newton_iterations) + " Newton iterations";
  // What the body pushed each convex with: minus the forces on the nodes, times h.
  const std::size_t first_convex = obstacles.planes.size();
  report.convex_impulse.assign(obstacles.convexes.size(), Vec3::Zero());
  report.convex_moment.assign(obstacles.convexes.size(), Vec3::Zero());
  for (Index i = 0; i < n; ++i) {
    state.v[i] = (x[i] - state.x[i]) / h;
    for (std::size_t j = 0; j < obstacle_count(obstacles); ++j) {
      const Vec3 f = potential.contact_force(i, j, x);
      if (f.isZero(0)) continue;
      ++report.contacts;
      if (j >= first_convex) {
        report.convex_impulse[j - first_convex] -= h * f;
        report.convex_moment[j - first_convex] -= h * x[i].cross(f);
      }
    }
  }
  for (const auto& f : d.friction)
    if (static_cast<std::size_t>(f.obstacle) >= first_convex) {
      const Vec3 force = potential.friction_force(f, x);
      report.convex_impulse[f.obstacle - first_convex] -= h * force;
      report.convex_moment[f.obstacle - first_convex] -= h * x[f.node].cross(force);
    }
  state.x.swap(x);
  return report;
}

double DynamicSolver::energy(const FemModel& model, const DynamicObstacles& obstacles,
                             const DynamicState& state) const {
  const double h = options_.time_step;
  double e = total_energy(model, state.x);
  for (Index i = 0; i < model.num_nodes; ++i) {
    const double m = model.node_mass[i];
    e += 0.5 * m * state.v[i].squaredNorm() - m * options_.gravity.dot(state.x[i]);
    for (std::size_t j = 0; j < obstacle_count(obstacles); ++j) {
      const double depth = touch(obstacles, j, state.x[i]).depth;
      if (depth > 0) e += 0.5 * options_.contact_stiffness * m / (h * h) * depth * depth;
    }
  }
  return e;
}

}  // namespace shatter
