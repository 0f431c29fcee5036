// Newton-Raphson for static equilibrium with line search and load stepping (method.md §2.3).
// Only tets with a free corner are evaluated: the others never change the free nodes' balance.
#include "shatter/solve/static_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "shatter/core/parallel.h"
#include "shatter/fem/tet_kernels.h"

namespace shatter {

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

Mat34 corners(const FemModel& model, const std::vector<Vec3>& x, Index e) {
  Mat34 xe;
  for (int k = 0; k < 4; ++k) xe.col(k) = x[model.tets[e][k]];
  return xe;
}

bool held(AnchorMask m, int c) { return (m & (1u << c)) != 0; }

// Smallest loops that go parallel (see parallel_for): about half a millisecond of work. An impact
// solve of a few thousand tets then runs without a single parallel region, so it cannot stall
// when the cores are oversubscribed.
constexpr std::int64_t kMinParallelForceTets = 2048;    // ~0.2 us per tet
constexpr std::int64_t kMinParallelEnergyTets = 8192;   // ~0.05 us per tet

std::string format_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

}  // namespace

StaticSolver::StaticSolver(const StaticSolverOptions& options)
    : options_(options), linear_(options.linear) {}

void StaticSolver::set_options(const StaticSolverOptions& options) {
  options_ = options;
  linear_.set_options(options.linear);
}

void StaticSolver::update_pattern(const FemModel& model, const std::vector<AnchorMask>& anchors) {
  if (has_pattern_ && matrix_.num_nodes() == model.num_nodes && pattern_tets_ == model.tets &&
      pattern_anchors_ == anchors)
    return;
  matrix_ = BlockSparseMatrix(model.num_nodes, model.tets, anchors);
  first_step_.resize(0);
  pattern_tets_ = model.tets;
  pattern_anchors_ = anchors;
  has_pattern_ = true;
  ++pattern_builds_;
}

void StaticSolver::active_forces(const FemModel& model, const std::vector<Vec3>& x) {
  const std::vector<Index>& tets = matrix_.active_tets();
  // Per-tet forces (and their round-off bounds) in one parallel loop, then a serial scatter in the
  // fixed active-tet order: every node sums its tets in the same order whatever the thread count.
  tet_force_.resize(tets.size());
  tet_force_error_.resize(tets.size());
  const double modulus = 2.0 * std::abs(model.lame.mu) + 3.0 * std::abs(model.lame.lambda);
  parallel_for(0, static_cast<std::int64_t>(tets.size()), [&](std::int64_t s) {
    const Index e = tets[static_cast<std::size_t>(s)];
    const TetRest& rest = model.rest[e];
    const Mat34 xe = corners(model, x, e);
    tet_force_[static_cast<std::size_t>(s)] = tet_internal_forces(model.model, model.lame, rest, xe);
    // Round-off estimate of each force component: the positions hold the displacements only to
    // eps |x| (absolute), and F - I cancels; both reach the stress through the moduli and the
    // force through V Dm^-T (f = V P Dm^-T).
    const double g1 = rest.Dm_inv.cwiseAbs().colwise().sum().maxCoeff();    // ||Dm^-1||_1
    const double ginf = rest.Dm_inv.cwiseAbs().rowwise().sum().maxCoeff();  // ||Dm^-1||_inf
    const double f_norm = deformation_gradient(rest, xe).cwiseAbs().maxCoeff();
    const double dF = std::numeric_limits<double>::epsilon() * (xe.cwiseAbs().maxCoeff() * g1 + f_norm);
    tet_force_error_[static_cast<std::size_t>(s)] =
        std::abs(rest.volume) * modulus * std::max(1.0, f_norm * f_norm) * dF * ginf;
  }, kMinParallelForceTets);
  force_.assign(x.size(), Vec3::Zero());
  force_error_.assign(x.size(), 0.0);
  for (std::size_t s = 0; s < tets.size(); ++s)
    for (int k = 0; k < 4; ++k) {
      const Index v = model.tets[tets[s]][k];
      force_[v] += tet_force_[s].col(k);
      force_error_[v] += tet_force_error_[s] * tet_force_error_[s];  // independent errors add in quadrature
    }
}

double StaticSolver::active_energy(const FemModel& model, const std::vector<Vec3>& x) const {
  const std::vector<Index>& tets = matrix_.active_tets();
  return parallel_sum(0, static_cast<std::int64_t>(tets.size()), 0.0, [&](std::int64_t s) {
    const Index e = tets[s];
    return tet_energy(model.model, model.lame, model.rest[e], corners(model, x, e));
  }, 512, kMinParallelEnergyTets);
}

Result<StaticReport> StaticSolver::solve(const FemModel& model, const StaticProblem& problem,
                                         std::vector<Vec3>& x) {
  const auto t_start = Clock::now();
  const Index n = model.num_nodes;
  const auto size_ok = [n](std::size_t s, bool may_be_empty) {
    return (may_be_empty && s == 0) || s == static_cast<std::size_t>(n);
  };
  if (!size_ok(x.size(), false))
    return field_error("x", "has " + std::to_string(x.size()) + " positions, the model " +
                                std::to_string(n) + " nodes");
  if (!size_ok(problem.anchors.size(), true))
    return field_error("anchors", "needs one mask per node (" + std::to_string(n) + ") or none");
  if (!size_ok(problem.anchor_positions.size(), true))
    return field_error("anchor_positions", "needs one position per node (" + std::to_string(n) + ") or none");
  if (!size_ok(problem.external_forces.size(), true))
    return field_error("external_forces", "needs one force per node (" + std::to_string(n) + ") or none");
  if (model.rest.size() != model.tets.size() || (problem.gravity && !size_ok(model.node_mass.size(), false)))
    return field_error("model", "is inconsistent (rest data or masses do not match the mesh)");

  StaticReport report;
  auto finish = [&](std::string message) -> Result<StaticReport> {
    report.message = std::move(message);
    report.converged = report.message.empty();
    report.total_ms = ms_since(t_start);
    return report;
  };

  // Non-finite input: report, leave x alone.
  const std::vector<AnchorMask> anchors =
      problem.anchors.empty() ? std::vector<AnchorMask>(static_cast<std::size_t>(n), anchor_none)
                              : problem.anchors;
  for (Index v = 0; v < n; ++v) {
    if (!x[v].allFinite()) return finish("initial position of node " + std::to_string(v) + " is not finite");
    if (!problem.external_forces.empty() && !problem.external_forces[v].allFinite())
      return finish("external force on node " + std::to_string(v) + " is not finite");
    if (!problem.anchor_positions.empty() && anchors[v] != anchor_none && !problem.anchor_positions[v].allFinite())
      return finish("anchor position of node " + std::to_string(v) + " is not finite");
  }
  if (problem.gravity && !problem.gravity_vector.allFinite()) return finish("gravity is not finite");
  if (!std::isfinite(model.lame.mu) || !std::isfinite(model.lame.lambda) || !(model.lame.mu > 0))
    return finish("material is not valid (Lame constants " + std::to_string(model.lame.mu) + ", " +
                  std::to_string(model.lame.lambda) + ")");
  for (Index e = 0; e < model.num_tets(); ++e)
    if (!(model.rest[e].volume > 0) || !model.rest[e].Dm_inv.allFinite())
      return finish("tet " + std::to_string(e) + " has a degenerate rest shape");

  {
    const auto t = Clock::now();
    update_pattern(model, anchors);
    report.assembly_ms += ms_since(t);
  }
  const Index na = matrix_.num_active();
  const std::vector<Index>& node_of_active = matrix_.node_of_active();

  // Full load per node, N.
  std::vector<Vec3> load(static_cast<std::size_t>(n), Vec3::Zero());
  for (Index v = 0; v < n; ++v) {
    if (!problem.external_forces.empty()) load[v] += problem.external_forces[v];
    if (problem.gravity) load[v] += model.node_mass[v] * problem.gravity_vector;
  }
  // Held components move from their initial to their prescribed values with the load fraction.
  const std::vector<Vec3> x_initial = x;
  auto set_anchors = [&](double s) {
    if (problem.anchor_positions.empty()) return;
    for (Index v = 0; v < n; ++v)
      for (int c = 0; c < 3; ++c)
        if (held(anchors[v], c))
          x[v][c] = x_initial[v][c] + s * (problem.anchor_positions[v][c] - x_initial[v][c]);
  };

  Eigen::VectorXd r(3 * na), dx(3 * na);
  double round_off = 0;  // estimated round-off in ||r|| at the last residual evaluation
  auto residual = [&](double s) {  // r = s f_ext - F(x) on free components; returns ||r||
    const auto t = Clock::now();
    active_forces(model, x);
    report.force_ms += ms_since(t);
    double round_off_sq = 0;
    for (Index a = 0; a < na; ++a) {
      const Index v = node_of_active[a];
      for (int c = 0; c < 3; ++c) {
        if (held(anchors[v], c)) {
          r[3 * a + c] = 0.0;
          continue;
        }
        r[3 * a + c] = s * load[v][c] - force_[v][c];
        round_off_sq += force_error_[v];
      }
    }
    round_off = std::sqrt(round_off_sq);
    return r.norm();
  };

  // Reference for the relative residual: the load on the free components, or with no load the
  // imbalance that the prescribed anchors cause.
  double reference = 0;
  for (Index a = 0; a < na; ++a) {
    const Index v = node_of_active[a];
    for (int c = 0; c < 3; ++c)
      if (!held(anchors[v], c)) reference += load[v][c] * load[v][c];
  }
  reference = std::sqrt(reference);
  if (!std::isfinite(reference)) return finish("external load is not finite");
  if (reference == 0) {
    set_anchors(1.0);
    reference = residual(0.0);
    set_anchors(0.0);
    if (!std::isfinite(reference)) {
      x = x_initial;
      return finish("internal forces are not finite at the prescribed anchor positions");
    }
    if (reference == 0) {  // already in equilibrium
      set_anchors(1.0);
      report.load_fraction = 1;
      report.load_steps = 1;
      return finish("");
    }
  }

  // One load step: Newton at load fraction s from the current x. Returns "" on success.
  const double armijo = 1e-4;
  auto newton = [&](double s) -> std::string {
    set_anchors(s);
    double energy = std::numeric_limits<double>::quiet_NaN();
    std::vector<Vec3> x_trial;
    double previous_rel = std::numeric_limits<double>::infinity();
    for (int it = 0;; ++it) {
      const double rel = residual(s) / reference;
      report.relative_residual = rel;
      if (!std::isfinite(rel)) return "internal forces are not finite";
      if (rel <= options_.relative_residual_tolerance) return "";
      // Round-off level: the residual is within the bound on its own evaluation error and the last
      // Newton step no longer reduced it. No further step can do better in double precision (the
      // positions carry small displacements of stiff bodies only to ~eps |x|).
      if (rel <= round_off / reference && rel > 0.5 * previous_rel) return "";
      if (it == options_.max_newton_iterations)
        return "no convergence in " + std::to_string(it) + " Newton iterations (relative residual " +
               format_number(rel) + ")";
      previous_rel = rel;
      {
        const auto t = Clock::now();
        assemble_stiffness(model, x, AssemblyOptions{.project_psd = options_.project_psd}, matrix_);
        report.assembly_ms += ms_since(t);
      }
      // Inexact Newton: the linear residual need only be a tenth of what the Newton tolerance
      // allows, ||K dx - r|| <= 0.1 tol reference (never tighter than the linear option).
      LinearSolverOptions linear = options_.linear;
      linear.relative_tolerance = std::max(
          linear.relative_tolerance,
          std::min(0.5, 0.1 * options_.relative_residual_tolerance / std::max(rel, 1e-300)));
      const bool pcg = linear.kind != LinearSolverKind::direct_ldlt;
      linear.warm_start = false;
      if (pcg && it == 0 && options_.warm_start && first_step_.size() == r.size()) {
        matrix_.multiply(first_step_, dx);
        const double dkd = first_step_.dot(dx);
        if (dkd > 0 && std::isfinite(dkd)) {
          dx = (r.dot(first_step_) / dkd) * first_step_;
          linear.warm_start = true;
        }
      }
      linear_.set_options(linear);
      const LinearSolveReport lin = linear_.solve(matrix_, r, dx);
      if (it == 0 && dx.allFinite()) first_step_ = dx;
      report.linear_solve_ms += lin.time_ms;
      report.linear_iterations_total += lin.iterations;
      ++report.newton_iterations;
      // An unconverged PCG still gives a usable (inexact Newton) direction; a failed one does not.
      if (!lin.converged && options_.linear.kind == LinearSolverKind::direct_ldlt)
        return "linear solve failed: " + lin.message;
      if (!dx.allFinite() || dx.squaredNorm() == 0.0) return "linear solve failed: " + lin.message;
      // Energy line search on E(x) = U(x) - s f_ext^T x; dE/dx = -r, so the slope along dx is -r.dx.
      const double slope = r.dot(dx);
      if (!(slope > 0)) return "Newton direction is not a descent direction";
      {
        const auto t = Clock::now();
        if (!std::isfinite(energy)) energy = active_energy(model, x);
        report.force_ms += ms_since(t);
      }
      double work = 0;  // s f_ext . dx
      for (Index a = 0; a < na; ++a)
        for (int c = 0; c < 3; ++c) work += s * load[node_of_active[a]][c] * dx[3 * a + c];
      double alpha = 1.0;
      bool accepted = false;
      for (int cut = 0; cut < 30; ++cut) {
        x_trial = x;
        for (Index a = 0; a < na; ++a) {
          const Index v = node_of_active[a];
          for (int c = 0; c < 3; ++c)
            if (!held(anchors[v], c)) x_trial[v][c] += alpha * dx[3 * a + c];
        }
        const auto t = Clock::now();
        const double trial_energy = active_energy(model, x_trial);
        report.force_ms += ms_since(t);
        const double change = (trial_energy - energy) - alpha * work;
        // Round-off slack: energies of stiff materials at small strain carry ~1e-12 relative error.
        const double slack = 1e-9 * (std::abs(energy) + std::abs(trial_energy));
        if (std::isfinite(change) && change <= -armijo * alpha * slope + slack) {
          x.swap(x_trial);
          energy = trial_energy;
          accepted = true;
          break;
        }
        if (!options_.line_search) break;
        alpha *= 0.5;
        ++report.line_search_cuts;
      }
      if (!accepted) return "line search found no energy decrease";
    }
  };

  double done = 0;
  const int increments = std::max(1, options_.load_increments);
  double step = 1.0 / increments;
  int halvings = 0;
  std::vector<Vec3> x_good = x;
  std::string failure;
  while (done < 1.0) {
    const double target = std::min(1.0, done + step);
    const std::string why = newton(target >= 1.0 - 1e-12 ? 1.0 : target);
    if (why.empty()) {
      done = target >= 1.0 - 1e-12 ? 1.0 : target;
      ++report.load_steps;
      x_good = x;
      continue;
    }
    x = x_good;
    if (halvings >= options_.max_load_halvings) {
      failure = why;
      break;
    }
    ++halvings;
    step *= 0.5;
  }
  report.load_fraction = done;
  if (!failure.empty()) {
    // Residual at the returned x against the full load.
    report.relative_residual = residual(1.0) / reference;
    return finish("load step failed at load fraction " + std::to_string(done) + " after " +
                  std::to_string(halvings) + " halvings: " + failure);
  }
  return finish("");
}

Result<StaticReport> solve_static(const FemModel& model, const StaticProblem& problem,
                                  std::vector<Vec3>& x, const StaticSolverOptions& options) {
  StaticSolver solver(options);
  return solver.solve(model, problem, x);
}

}  // namespace shatter
