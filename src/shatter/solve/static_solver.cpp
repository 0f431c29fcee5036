// Newton-Raphson for static equilibrium with line search and load stepping (docs/method.md §2.3).
// Only tets with a free corner are evaluated: the others never change the free nodes' balance.
#include "shatter/solve/static_solver.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <utility>

#include "shatter/core/clock.h"
#include "shatter/core/parallel.h"
#include "shatter/fem/tet_kernels.h"

namespace shatter {

namespace {

Mat34 corners(const FemModel& model, const std::vector<Vec3>& x, Index e) {
  Mat34 xe;
  for (int k = 0; k < 4; ++k) xe.col(k) = x[model.tets[e][k]];
  return xe;
}

// Smallest loops that go parallel (see parallel_for): about half a millisecond of work. An impact
// solve of a few thousand tets then runs without a single parallel region, so it cannot stall
// when the cores are oversubscribed.
constexpr std::int64_t kMinParallelForceTets = 2048;  // forces and energy, ~0.2-0.4 us per tet

// Armijo constant of the energy line search: a step must realise this fraction of the energy
// decrease that the slope predicts.
constexpr double kArmijo = 1e-4;

// Sizes of the inputs against the model: errors, not reports (the caller passed wrong arrays).
Result<void> check_sizes(const FemModel& model, const StaticProblem& problem, const std::vector<Vec3>& x) {
  const Index n = model.num_nodes;
  const auto size_ok = [n](std::size_t s, bool may_be_empty) {
    return (may_be_empty && s == 0) || s == static_cast<std::size_t>(n);
  };
  if (!size_ok(x.size(), false))
    return field_error("x",
                       "has " + std::to_string(x.size()) + " positions, the model " + std::to_string(n) + " nodes");
  if (!size_ok(problem.anchors.size(), true))
    return field_error("anchors", "needs one mask per node (" + std::to_string(n) + ") or none");
  if (!size_ok(problem.anchor_positions.size(), true))
    return field_error("anchor_positions", "needs one position per node (" + std::to_string(n) + ") or none");
  if (!size_ok(problem.external_forces.size(), true))
    return field_error("external_forces", "needs one force per node (" + std::to_string(n) + ") or none");
  if (model.rest.size() != model.tets.size() || (problem.gravity && !size_ok(model.node_mass.size(), false)))
    return field_error("model", "is inconsistent (rest data or masses do not match the mesh)");
  return {};
}

}  // namespace

StaticSolver::StaticSolver(const StaticSolverOptions& options) : options_(options), linear_(options.linear) {}

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
  direct_checked_ = false;
  prefer_direct_ = false;
  prefer_two_level_ = false;
  direct_cost_ = pcg_cost_ = two_level_setup_ = two_level_iteration_ = 0;
  pattern_tets_ = model.tets;
  pattern_anchors_ = anchors;
  has_pattern_ = true;
  ++pattern_builds_;
}

double StaticSolver::tet_forces(const FemModel& model, const std::vector<Vec3>& x, std::size_t s,
                                std::vector<Mat34>& force, std::vector<double>& error,
                                std::vector<Polar>& polar) const {
  const Index e = matrix_.active_tets()[s];
  const TetRest& rest = model.rest[e];
  const Mat34 xe = corners(model, x, e);
  const Mat3 F = deformation_gradient(rest, xe);
  double energy = 0;
  if (model.model == ModelKind::corotated) {
    // One polar decomposition for the energy, the forces and the stiffness refill at this x.
    Polar& p = polar[static_cast<std::size_t>(e)];
    p = polar_decomposition(F);
    energy = rest.volume * corotated_energy_density(model.lame, F, p);
    force[s] = tet_forces_from_stress(rest, corotated_first_piola(model.lame, F, p));
  } else {
    energy = rest.volume * energy_density(model.model, model.lame, F);
    force[s] = tet_forces_from_stress(rest, first_piola(model.model, model.lame, F));
  }
  // Round-off estimate of each force component: the positions hold the displacements only to
  // eps |x| (absolute), and F - I cancels; both reach the stress through the moduli and the force
  // through V Dm^-T (f = V P Dm^-T).
  const double modulus = 2.0 * std::abs(model.lame.mu) + 3.0 * std::abs(model.lame.lambda);
  const double g1 = rest.Dm_inv.cwiseAbs().colwise().sum().maxCoeff();    // ||Dm^-1||_1
  const double ginf = rest.Dm_inv.cwiseAbs().rowwise().sum().maxCoeff();  // ||Dm^-1||_inf
  const double f_norm = F.cwiseAbs().maxCoeff();
  const double dF = std::numeric_limits<double>::epsilon() * (xe.cwiseAbs().maxCoeff() * g1 + f_norm);
  error[s] = std::abs(rest.volume) * modulus * std::max(1.0, f_norm * f_norm) * dF * ginf;
  return energy;
}

void StaticSolver::active_forces(const FemModel& model, const std::vector<Vec3>& x) {
  const std::vector<Index>& tets = matrix_.active_tets();
  if (!trial_at_.empty() && trial_at_ == x) {
    // The accepted line-search trial: its forces were found with its energy.
    tet_force_.swap(trial_force_);
    tet_force_error_.swap(trial_force_error_);
    tet_polar_.swap(trial_polar_);
    forces_at_.swap(trial_at_);
    trial_at_.clear();
  } else {
    // Per-tet forces (and their round-off bounds) in one parallel loop.
    tet_force_.resize(tets.size());
    tet_force_error_.resize(tets.size());
    if (model.model == ModelKind::corotated) tet_polar_.resize(static_cast<std::size_t>(model.num_tets()));
    parallel_for(
        0, static_cast<std::int64_t>(tets.size()),
        [&](std::int64_t s) {
          tet_forces(model, x, static_cast<std::size_t>(s), tet_force_, tet_force_error_, tet_polar_);
        },
        kMinParallelForceTets);
    forces_at_ = x;
  }
  // A serial scatter in the fixed active-tet order: every node sums its tets in the same order
  // whatever the thread count.
  force_.assign(x.size(), Vec3::Zero());
  force_error_.assign(x.size(), 0.0);
  for (std::size_t s = 0; s < tets.size(); ++s)
    for (int k = 0; k < 4; ++k) {
      const Index v = model.tets[tets[s]][k];
      force_[v] += tet_force_[s].col(k);
      force_error_[v] += tet_force_error_[s] * tet_force_error_[s];  // independent errors add in quadrature
    }
}

double StaticSolver::active_energy(const FemModel& model, const std::vector<Vec3>& x) {
  const std::vector<Index>& tets = matrix_.active_tets();
  if (forces_at_ == x) {
    // Where the forces are known (a load step's first line search): the energy alone, from the
    // polar decompositions found with them.
    const bool corotated = model.model == ModelKind::corotated;
    return parallel_sum(
        0, static_cast<std::int64_t>(tets.size()), 0.0,
        [&](std::int64_t s) {
          const Index e = tets[static_cast<std::size_t>(s)];
          const TetRest& rest = model.rest[e];
          const Mat3 F = deformation_gradient(rest, corners(model, x, e));
          return rest.volume * (corotated ? corotated_energy_density(model.lame, F, tet_polar_[e])
                                          : energy_density(model.model, model.lame, F));
        },
        512, kMinParallelForceTets);
  }
  trial_force_.resize(tets.size());
  trial_force_error_.resize(tets.size());
  if (model.model == ModelKind::corotated) trial_polar_.resize(static_cast<std::size_t>(model.num_tets()));
  trial_at_.clear();  // not valid while being refilled
  const double energy = parallel_sum(
      0, static_cast<std::int64_t>(tets.size()), 0.0,
      [&](std::int64_t s) {
        return tet_forces(model, x, static_cast<std::size_t>(s), trial_force_, trial_force_error_, trial_polar_);
      },
      512, kMinParallelForceTets);
  trial_at_ = x;
  return energy;
}

/// How a step of a solve ended: converged (go on), or the failure and why.
struct StaticSolver::Outcome {
  SolveStatus status = SolveStatus::converged;
  std::string message;  ///< why it failed ("" when converged)
  [[nodiscard]] bool ok() const { return status == SolveStatus::converged; }
};

/// What one solve() call shares between its steps: its inputs, the per-solve arrays and the report.
struct StaticSolver::SolveState {
  SolveState(const FemModel& fem_model, const StaticProblem& static_problem, std::vector<Vec3>& positions)
      : model(fem_model), problem(static_problem), x(positions), n(fem_model.num_nodes) {}

  /// Held components move from their initial to their prescribed values with the load fraction s.
  void set_anchors(double s) {
    if (problem.anchor_positions.empty()) return;
    for (Index v = 0; v < n; ++v)
      for (int c = 0; c < 3; ++c)
        if (held(anchors[v], c)) x[v][c] = x_initial[v][c] + s * (problem.anchor_positions[v][c] - x_initial[v][c]);
  }

  /// The report with the outcome and the total time filled in.
  Result<StaticReport> finish(Outcome outcome) {
    report.status = outcome.status;
    report.message = std::move(outcome.message);
    report.converged = outcome.ok();
    report.total_ms = ms_since(start);
    return std::move(report);
  }

  const FemModel& model;
  const StaticProblem& problem;
  std::vector<Vec3>& x;  ///< the caller's positions, m (#nodes): the current iterate
  const Index n;         ///< #nodes
  const Clock::time_point start = Clock::now();
  std::vector<AnchorMask> anchors;  ///< held components per node (#nodes; problem.anchors, or none held)
  std::vector<Vec3> x_initial;      ///< x as passed in, m (#nodes)
  std::vector<Vec3> load;           ///< full external load per node, N (#nodes)
  double reference = 0;             ///< what relative residuals divide by, N
  bool load_reference = false;      ///< reference is the external load (not an anchor imbalance)
  Eigen::VectorXd r;                ///< residual s f_ext - F(x), N (3 #active nodes; 0 on held components)
  Eigen::VectorXd dx;               ///< Newton step, m (3 #active nodes)
  double round_off = 0;             ///< estimated round-off in ||r|| at the last residual evaluation, N
  double energy = std::numeric_limits<double>::quiet_NaN();  ///< U(x) of the active tets, J (NaN: not yet known)
  std::vector<Vec3> x_trial;                                 ///< line-search trial positions, m (#nodes)
  double step_length = 0;          ///< the last line search's accepted fraction of the step (0: none)
  bool last_direct = false;        ///< the last linear solve was the direct one
  bool have_tangent = false;       ///< the matrix holds a tangent assembled in this solve
  bool tangent_projected = false;  ///< ... the projected one
  double chord_from = -1;          ///< relative residual the last chord step started from (-1: it assembled)
  /// Residual ratios (after / before) of the load step's last assembled and last chord steps
  /// (-1: none yet in this load step).
  double assembled_rate = -1;
  double chord_rate = -1;
  bool out_of_iterations = false;  ///< StaticSolverOptions::max_total_newton_iterations ran out
  double step_tolerance = 0;       ///< relative residual the current load step must reach
  StaticReport report;
};

const char* to_string(TangentKind kind) {
  switch (kind) {
    case TangentKind::on_demand: return "on-demand";
    case TangentKind::projected: return "projected";
    case TangentKind::exact: return "exact";
    case TangentKind::by_model: return "by-model";
  }
  return "?";
}

Result<TangentKind> parse_tangent_kind(std::string_view name) {
  for (TangentKind k : {TangentKind::on_demand, TangentKind::projected, TangentKind::exact, TangentKind::by_model})
    if (name == to_string(k)) return k;
  return field_error("tangent",
                     "unknown tangent '" + std::string(name) + "'; expected on-demand, projected, exact or by-model");
}

TangentKind resolve_tangent(TangentKind kind, ModelKind model) {
  if (kind != TangentKind::by_model) return kind;
  return model == ModelKind::stvk ? TangentKind::projected : TangentKind::on_demand;
}

const char* to_string(SolveStatus status) {
  switch (status) {
    case SolveStatus::converged: return "converged";
    case SolveStatus::invalid_input: return "invalid-input";
    case SolveStatus::not_finite: return "not-finite";
    case SolveStatus::no_convergence: return "no-convergence";
    case SolveStatus::line_search_failed: return "line-search-failed";
    case SolveStatus::linear_solve_failed: return "linear-solve-failed";
  }
  return "?";
}

Result<StaticReport> StaticSolver::solve(const FemModel& model, const StaticProblem& problem, std::vector<Vec3>& x) {
  SolveState st(model, problem, x);
  if (Result<void> sizes = check_sizes(model, problem, x); !sizes.ok()) return std::move(sizes.error());
  st.anchors =
      problem.anchors.empty() ? std::vector<AnchorMask>(static_cast<std::size_t>(st.n), anchor_none) : problem.anchors;
  if (Outcome input = check_inputs(st); !input.ok()) return st.finish(std::move(input));
  if (std::optional<Outcome> early = prepare(st)) return st.finish(std::move(*early));
  // A factorization is reused within a solve only: the result depends on this solve's input alone.
  linear_.forget_factorization();
  linear_.set_node_positions(x);

  // Load stepping (automatic increments, as CalculiX's): easy steps let the next one grow, hard
  // ones make it shrink, and a failed step restarts from the last equilibrium at half the size.
  double done = 0;
  const int increments = std::max(1, options_.load_increments);
  double step = 1.0 / increments;
  int halvings = 0;
  std::vector<Vec3> x_good = x;
  Outcome failure;
  Outcome last_failure;  // the last failed load step's (limit_resolution)
  const double final_tolerance = options_.relative_residual_tolerance;
  const double intermediate_tolerance = std::max(options_.intermediate_tolerance, final_tolerance);
  // The lowest fraction whose load step failed, and the size of that step (limit_resolution).
  double lowest_failed = std::numeric_limits<double>::infinity();
  double failed_step = 0;
  const bool bracket = options_.limit_resolution > 0;
  bool bounded = false;  // the last failed step bounds the search (limit_resolution)
  while (done < 1.0) {
    double target = std::min(1.0, done + step);
    // Toward a failed fraction (limit_resolution): three quarters of the way, unless the step is a
    // retry from much closer. Near a limit point a step that lands close below it converges (in
    // more iterations), and it leaves less of the gap for later steps: the clay teddy's landing
    // reaches the fraction that bisection reaches (0.4375) in 24 Newton iterations instead of 33.
    if (bracket && target >= lowest_failed && target - done > 0.25 * failed_step)
      target = done + 0.75 * (lowest_failed - done);
    // A step smaller than the resolution that stays below a failed fraction is not worth its
    // iterations (once the last failed step bounds the search): the solve ends at the fraction
    // reached.
    if (bounded && target < lowest_failed && target - done < options_.limit_resolution) {
      failure = {last_failure.status, "the load in equilibrium is bracketed below " + format_number(lowest_failed, 3) +
                                          " (limit resolution " + format_number(options_.limit_resolution, 3) +
                                          "); the last failed step: " + last_failure.message};
      break;
    }
    // Snap to the full load when the summed steps fall short of it only by round-off.
    const double s = target >= 1.0 - 1e-12 ? 1.0 : target;
    int iterations = 0;
    Outcome why = newton_load_step(st, s, s == 1.0 ? final_tolerance : intermediate_tolerance, iterations);
    if (why.ok()) {
      done = s;
      ++st.report.load_steps;
      x_good = x;
      if (iterations <= kEasyLoadStep) step *= 1.5;
      if (iterations > kHardLoadStep) step *= 0.75;
      continue;
    }
    // A step that brought its residual under the intermediate tolerance failed on the (tighter)
    // final one, not for want of an equilibrium (limit_resolution): it bounds nothing. At the full
    // load its state is a better equilibrium than any fraction below it, and the solve ends there,
    // not converged (a StVK teddy's rebound: 10 iterations to 3e-4, where the retries from below
    // took 47 and ended at 0.875 of the load); below it, the steps go on.
    const bool near = st.report.relative_residual <= intermediate_tolerance;
    if (bracket && near && s == 1.0) {
      done = s;
      failure = std::move(why);
      break;
    }
    x = x_good;
    bounded = bracket && !near;
    if (bounded && s <= lowest_failed) {
      lowest_failed = s;
      failed_step = s - done;
    }
    if (halvings >= options_.max_load_halvings || st.out_of_iterations) {
      failure = std::move(why);
      break;
    }
    last_failure = why;
    ++halvings;
    ++st.report.load_step_failures;
    step = 0.5 * (s - done);
  }
  st.report.load_fraction = done;
  if (failure.ok()) {
    record_final(st);
    return st.finish({});
  }
  // Residual at the returned x against the full load.
  st.report.relative_residual = residual(st, 1.0) / st.reference;
  record_final(st);
  return st.finish({failure.status, "load step failed at load fraction " + format_number(done, 3) + " after " +
                                        std::to_string(halvings) + " halvings: " + failure.message});
}

StaticSolver::Outcome StaticSolver::check_inputs(const SolveState& st) {
  // Non-finite input: report, leave x alone.
  const FemModel& model = st.model;
  const StaticProblem& problem = st.problem;
  const auto invalid = [](std::string message) { return Outcome{SolveStatus::invalid_input, std::move(message)}; };
  for (Index v = 0; v < st.n; ++v) {
    if (!st.x[v].allFinite()) return invalid("initial position of node " + std::to_string(v) + " is not finite");
    if (!problem.external_forces.empty() && !problem.external_forces[v].allFinite())
      return invalid("external force on node " + std::to_string(v) + " is not finite");
    if (!problem.anchor_positions.empty() && st.anchors[v] != anchor_none && !problem.anchor_positions[v].allFinite())
      return invalid("anchor position of node " + std::to_string(v) + " is not finite");
  }
  if (problem.gravity && !problem.gravity_vector.allFinite()) return invalid("gravity is not finite");
  if (!std::isfinite(model.lame.mu) || !std::isfinite(model.lame.lambda) || !(model.lame.mu > 0))
    return invalid("material is not valid (Lame constants " + std::to_string(model.lame.mu) + ", " +
                   std::to_string(model.lame.lambda) + ")");
  for (Index e = 0; e < model.num_tets(); ++e)
    if (!(model.rest[e].volume > 0) || !model.rest[e].Dm_inv.allFinite())
      return invalid("tet " + std::to_string(e) + " has a degenerate rest shape");
  return {};
}

std::optional<StaticSolver::Outcome> StaticSolver::prepare(SolveState& st) {
  // Forces kept from an earlier solve belong to its model.
  forces_at_.clear();
  trial_at_.clear();
  {
    const auto t = Clock::now();
    update_pattern(st.model, st.anchors);
    st.report.assembly_ms += ms_since(t);
  }
  // Full load per node, N.
  st.load.assign(static_cast<std::size_t>(st.n), Vec3::Zero());
  for (Index v = 0; v < st.n; ++v) {
    if (!st.problem.external_forces.empty()) st.load[v] += st.problem.external_forces[v];
    if (st.problem.gravity) st.load[v] += st.model.node_mass[v] * st.problem.gravity_vector;
  }
  st.x_initial = st.x;
  st.r.resize(3 * matrix_.num_active());
  st.dx.resize(3 * matrix_.num_active());
  return set_reference(st);
}

std::optional<StaticSolver::Outcome> StaticSolver::set_reference(SolveState& st) {
  // Reference for the relative residual: the load on the free components, or with no load the
  // imbalance that the prescribed anchors cause.
  const std::vector<Index>& node_of_active = matrix_.node_of_active();
  double reference = 0;
  for (Index a = 0; a < matrix_.num_active(); ++a) {
    const Index v = node_of_active[a];
    for (int c = 0; c < 3; ++c)
      if (!held(st.anchors[v], c)) reference += st.load[v][c] * st.load[v][c];
  }
  st.reference = std::sqrt(reference);
  if (!std::isfinite(st.reference)) return Outcome{SolveStatus::invalid_input, "external load is not finite"};
  st.load_reference = st.reference != 0;
  if (st.reference != 0) return std::nullopt;
  st.set_anchors(1.0);
  st.reference = residual(st, 0.0);
  st.set_anchors(0.0);
  if (!std::isfinite(st.reference)) {
    st.x = st.x_initial;
    return Outcome{SolveStatus::not_finite, "internal forces are not finite at the prescribed anchor positions"};
  }
  if (st.reference == 0) {  // already in equilibrium
    st.set_anchors(1.0);
    st.report.load_fraction = 1;
    st.report.load_steps = 1;
    return Outcome{};
  }
  return std::nullopt;
}

double StaticSolver::residual(SolveState& st, double s) {
  const auto t = Clock::now();
  active_forces(st.model, st.x);
  st.report.force_ms += ms_since(t);
  const std::vector<Index>& node_of_active = matrix_.node_of_active();
  double round_off_sq = 0;
  for (Index a = 0; a < matrix_.num_active(); ++a) {
    const Index v = node_of_active[a];
    for (int c = 0; c < 3; ++c) {
      if (held(st.anchors[v], c)) {
        st.r[3 * a + c] = 0.0;
        continue;
      }
      st.r[3 * a + c] = s * st.load[v][c] - force_[v][c];
      round_off_sq += force_error_[v];
    }
  }
  st.round_off = std::sqrt(round_off_sq);
  return st.r.norm();
}

StaticSolver::Outcome StaticSolver::newton_load_step(SolveState& st, double s, double tolerance, int& iterations) {
  st.set_anchors(s);
  st.step_tolerance = tolerance;
  st.energy = std::numeric_limits<double>::quiet_NaN();
  double previous_rel = std::numeric_limits<double>::infinity();
  const bool linear_model = st.model.model == ModelKind::linear;
  std::array<double, 4> recent{};  // relative residuals of the last four iterations, by it % 4
  for (int it = 0;; ++it) {
    iterations = it;
    const double rel = residual(st, s) / st.reference;
    if (it == 0) {
      st.assembled_rate = st.chord_rate = -1;
    } else {
      (st.chord_from >= 0 ? st.chord_rate : st.assembled_rate) = rel / previous_rel;
    }
    const double rel_three_before = recent[static_cast<std::size_t>((it + 1) % 4)];
    recent[static_cast<std::size_t>(it % 4)] = rel;
    st.report.relative_residual = rel;
    if (!std::isfinite(rel)) return {SolveStatus::not_finite, "internal forces are not finite"};
    if (rel <= tolerance) return {};
    // Round-off level: the residual is within the bound on its own evaluation error and the last
    // Newton step no longer reduced it. No further step can do better in double precision (the
    // positions carry small displacements of stiff bodies only to ~eps |x|).
    // The linear model's residual is linear in x: after one step it is what the linear solve left
    // plus round-off, and no further step can lower it, so it need not be seen to stall.
    if (rel <= st.round_off / st.reference && (rel > 0.5 * previous_rel || linear_model)) {
      // Only a load can be missed: with none, the reference is itself an imbalance of round-off
      // size (a body at rest) and a relative residual near 1 is the right answer.
      if (rel <= options_.max_round_off_residual || !st.load_reference) return {};
      return {SolveStatus::no_convergence,
              "the residual stalls at its round-off level, relative residual " + format_number(rel, 3) + " (above " +
                  format_number(options_.max_round_off_residual, 3) +
                  "): the displacements are below what double precision resolves at this mesh's coordinates "
                  "and size (check the units; a mesh far from the origin is solved about its centre by "
                  "shatter static)"};
    }
    if (it == options_.max_newton_iterations)
      return {SolveStatus::no_convergence, "no convergence in " + std::to_string(it) +
                                               " Newton iterations (relative residual " + format_number(rel, 3) + ")"};
    // A step predicted to miss its tolerance by far ends now instead of at the iteration limit:
    // from the rate over the last three iterations, rho = (r_k / r_(k-3))^(1/3), it needs
    // log(tol / r) / log(rho) more, and is given up when that is more than twice the iterations
    // left (or the residual is not falling). Before its limit a hopeless step spends as much as
    // the rest of the solve (the clay teddy's: 12 iterations each, of 61).
    if (options_.abandon_slow_load_steps && it >= 4) {
      const double rho = std::cbrt(rel / rel_three_before);
      const int left = options_.max_newton_iterations - it;
      if (!(rho < 1.0) || std::log(tolerance / rel) / std::log(rho) > 2.0 * left)
        return {SolveStatus::no_convergence, "the residual falls too slowly to converge in " +
                                                 std::to_string(options_.max_newton_iterations) +
                                                 " Newton iterations (relative residual " + format_number(rel, 3) +
                                                 ", falling by " + format_number(rho, 3) + " per iteration)"};
    }
    if (options_.max_total_newton_iterations > 0 &&
        st.report.newton_iterations >= options_.max_total_newton_iterations) {
      st.out_of_iterations = true;
      return {SolveStatus::no_convergence, "the solve's " + std::to_string(options_.max_total_newton_iterations) +
                                               " Newton iterations ran out (relative residual " +
                                               format_number(rel, 3) + ")"};
    }
    previous_rel = rel;
    if (Outcome step = newton_iteration(st, s, it, rel); !step.ok()) return step;
  }
}

StaticSolver::Outcome StaticSolver::newton_iteration(SolveState& st, double s, int iteration,
                                                     double relative_residual) {
  NewtonIteration record{.load_fraction = s, .relative_residual = relative_residual};
  const int linear_before = st.report.linear_iterations_total;
  const auto finish = [&](Outcome outcome) {
    record.linear_iterations = st.report.linear_iterations_total - linear_before;
    if (options_.record_history) st.report.history.push_back(record);
    ++st.report.newton_iterations;
    if (record.projected) ++st.report.projected_iterations;
    if (record.direct) ++st.report.direct_iterations;
    return outcome;
  };
  // Project on demand: the exact stiffness first (quadratic convergence where it is positive
  // definite), the projected one where the exact one fails to give an energy decrease.
  const TangentKind tangent = resolve_tangent(options_.tangent, st.model.model);
  const bool on_demand = tangent == TangentKind::on_demand;
  if (tangent != TangentKind::projected) {
    bool indefinite = false;
    Outcome direction = newton_direction(st, iteration, relative_residual, false, indefinite);
    if (!on_demand && !direction.ok()) return finish(std::move(direction));
    record.direct = st.last_direct;
    if (direction.ok() && !(on_demand && indefinite)) {
      Outcome step = line_search(st, s);
      record.step_length = st.step_length;
      if (step.ok() || !on_demand) return finish(std::move(step));
    }
  }
  record.projected = true;
  bool indefinite = false;
  if (Outcome direction = newton_direction(st, iteration, relative_residual, true, indefinite); !direction.ok())
    return finish(std::move(direction));
  Outcome step = line_search(st, s);
  record.step_length = st.step_length;
  record.direct = st.last_direct;
  return finish(std::move(step));
}

void StaticSolver::record_final(SolveState& st) const {
  if (options_.record_history)
    st.report.history.push_back(
        NewtonIteration{.load_fraction = st.report.load_fraction, .relative_residual = st.report.relative_residual});
}

StaticSolver::Outcome StaticSolver::newton_direction(SolveState& st, int iteration, double relative_residual,
                                                     bool projected, bool& indefinite) {
  // A chord step: the last tangent again (and with the direct solver its factorization).
  //  - Near the solution, while each such step cuts the residual tenfold
  //    (StaticSolverOptions::chord_tolerance).
  //  - Where assembled steps converge only linearly (each cut the residual by less than
  //    1 / kChordLinearRate: the projected tangent of a body compressed far), with the direct
  //    solver, while each chord step cuts it at least as much as an assembled step does per unit of
  //    cost (rate_chord <= rate_assembled^kChordCost) and, chord steps counting as iterations, the
  //    load step's tolerance is within reach of the iterations left at that rate (the last chord
  //    step's in this load step; before one, the assembled rate).
  const bool same_tangent = options_.chord_tolerance > 0 && st.have_tangent && st.tangent_projected == projected;
  const bool near =
      relative_residual < options_.chord_tolerance && (st.chord_from < 0 || relative_residual < 0.1 * st.chord_from);
  bool linear_regime = false;
  if (st.last_direct && st.assembled_rate > kChordLinearRate && st.assembled_rate < 1) {
    const double pays = std::pow(st.assembled_rate, kChordCost);
    const double rate = st.chord_rate >= 0 ? st.chord_rate : st.assembled_rate;
    const int left = options_.max_newton_iterations - iteration - 1;
    linear_regime = rate <= pays && std::log(st.step_tolerance / relative_residual) / std::log(rate) <= left;
  }
  const bool chord = same_tangent && (near || linear_regime);
  if (chord) {
    st.chord_from = relative_residual;
    ++st.report.chord_iterations;
  } else {
    const auto t = Clock::now();
    // A corotated refill reads the polar decompositions that the residual at this x found.
    const bool have_polar = st.model.model == ModelKind::corotated && forces_at_ == st.x;
    assemble_stiffness(st.model, st.x, AssemblyOptions{.project_psd = projected}, matrix_,
                       have_polar ? std::span<const Polar>(tet_polar_) : std::span<const Polar>());
    st.report.assembly_ms += ms_since(t);
    st.have_tangent = true;
    st.tangent_projected = projected;
    st.chord_from = -1;
  }
  // Inexact Newton: the linear residual need only be a tenth of what the load step's tolerance
  // allows, ||K dx - r|| <= 0.1 tol reference (never tighter than the linear option): an
  // intermediate load step (StaticSolverOptions::intermediate_tolerance) needs less than the last.
  LinearSolverOptions linear = options_.linear;
  // Once chosen, the direct solver keeps its factorization while CG preconditioned by it converges
  // quickly (LinearSolverOptions::reuse_factorization).
  if (prefer_direct_) linear.kind = LinearSolverKind::direct_ldlt;
  if (prefer_two_level_) linear.kind = LinearSolverKind::pcg_two_level;
  linear.reuse_factorization = prefer_direct_;
  const double forcing = 0.1 * st.step_tolerance / std::max(relative_residual, 1e-300);
  linear.relative_tolerance = std::max(linear.relative_tolerance, std::min(0.5, forcing));
  bool pcg = linear.kind != LinearSolverKind::direct_ldlt;
  linear.warm_start = false;
  if (pcg && iteration == 0 && options_.warm_start && first_step_.size() == st.r.size()) {
    matrix_.multiply(first_step_, st.dx);
    const double dkd = first_step_.dot(st.dx);
    if (dkd > 0 && std::isfinite(dkd)) {
      st.dx = (st.r.dot(first_step_) / dkd) * first_step_;
      linear.warm_start = true;
    }
  }
  // direct_when_cheaper: PCG gets kMinIterationsForDirect iterations first. A system it cannot
  // solve in those is ill-conditioned (a body held at a few nodes, a slender or soft part); then
  // three ways on are weighed, by multiply-adds (deterministic, unlike times), and the cheapest
  // solves this step and the rest of the solves on this pattern:
  //  - more PCG iterations, as many as the rate of the first ones predicts: each a matrix-vector
  //    product, two Gauss-Seidel (or one Jacobi) sweeps over the stored values and a few vector
  //    updates;
  //  - a factorization: the multiply-adds of a scalar LDL^T with its fill (counted twice) and two
  //    triangular solves;
  //  - PCG with the two-level preconditioner (pcg_two_level), which removes what the sweeps leave
  //    at long wavelengths: per solve the coarse matrix and its factorization, then about
  //    kTwoLevelIterations iterations of twice a Gauss-Seidel iteration's work.
  const int max_pcg = linear.max_iterations;
  bool weigh = pcg && options_.direct_when_cheaper && !direct_checked_ && max_pcg > kMinIterationsForDirect;
  // Choose the factorization, the two-level PCG or `pcg_iterations` more of the same PCG (+inf:
  // not measured) by their costs, for this solve and the rest on this pattern.
  const auto choose = [&](double pcg_iterations) {
    direct_checked_ = true;
    const auto t = Clock::now();
    const DirectCost direct = linear_.direct_cost(matrix_);
    st.report.linear_solve_ms += ms_since(t);
    const double values = static_cast<double>(matrix_.num_values());
    const double unknowns = static_cast<double>(matrix_.size());
    const double pcg_cost = pcg_iterations * (4.0 * values + 10.0 * unknowns);
    const double direct_cost = 2.0 * direct.factor_flops + 4.0 * direct.factor_nonzeros;
    const double aggregates =
        std::clamp(std::floor(static_cast<double>(matrix_.num_active()) / std::max(1, linear.min_aggregate_nodes)), 1.0,
                   static_cast<double>(std::max(1, linear.max_aggregates)));
    const double coarse = 6.0 * aggregates;
    two_level_setup_ = 12.0 * values + coarse * coarse * coarse / 3.0;
    two_level_iteration_ = 8.0 * values + 20.0 * unknowns + 2.0 * coarse * coarse;
    const double two_level_cost = two_level_setup_ + kTwoLevelIterations * two_level_iteration_;
    prefer_direct_ = direct_cost < std::min(pcg_cost, two_level_cost);
    prefer_two_level_ = !prefer_direct_ && two_level_cost < pcg_cost;
    // What the two-level solves are held to (below).
    direct_cost_ = direct_cost;
    pcg_cost_ = pcg_cost;
    if (prefer_direct_) {
      linear.kind = LinearSolverKind::direct_ldlt;
      pcg = false;
    } else if (prefer_two_level_) {
      linear.kind = LinearSolverKind::pcg_two_level;
    }
  };
  if (weigh && options_.ill_conditioned) {
    choose(std::numeric_limits<double>::infinity());
    weigh = false;
  }
  if (weigh) linear.max_iterations = kMinIterationsForDirect;
  linear_.set_options(linear);
  LinearSolveReport lin = linear_.solve(matrix_, st.r, st.dx);
  if (weigh && !lin.converged && !lin.indefinite && lin.iterations == kMinIterationsForDirect) {
    // The iterations PCG still needs, from the rate of its first ones (relative residual = rate^k),
    // at most its iteration limit. A residual that did not drop at all (CG's residual is not
    // monotone) counts as the whole limit.
    const double reached = std::clamp(lin.relative_residual, 1e-300, 0.999);
    choose(std::min(
        static_cast<double>(max_pcg - kMinIterationsForDirect),
        kMinIterationsForDirect * std::max(1.0, std::log(linear.relative_tolerance) / std::log(reached) - 1.0)));
    st.report.linear_solve_ms += lin.time_ms;
    st.report.linear_iterations_total += lin.iterations;
    if (pcg) {
      linear.max_iterations = max_pcg - lin.iterations;
      linear.warm_start = true;
    }
    linear_.set_options(linear);
    lin = linear_.solve(matrix_, st.r, st.dx);
  }
  // The two-level PCG was chosen on an expected iteration count. A solve that took so many that
  // it cost more than the runner-up (tight tolerances, a tangent near buckling: the soft
  // cantilever took 200 per step) hands the rest of the solves on this pattern to that one.
  if (prefer_two_level_ && linear.kind == LinearSolverKind::pcg_two_level &&
      two_level_setup_ + lin.iterations * two_level_iteration_ > std::min(direct_cost_, pcg_cost_)) {
    prefer_two_level_ = false;
    prefer_direct_ = direct_cost_ < pcg_cost_;
  }
  indefinite = lin.indefinite;
  st.last_direct = !pcg;
  st.report.linear_solve_ms += lin.time_ms;
  st.report.linear_iterations_total += lin.iterations;
  if (iteration == 0 && st.dx.allFinite() && !lin.indefinite) first_step_ = st.dx;
  // An unconverged PCG still gives a usable (inexact Newton) direction; a failed one does not.
  if (!lin.converged && !pcg) return {SolveStatus::linear_solve_failed, "linear solve failed: " + lin.message};
  if (!st.dx.allFinite() || st.dx.squaredNorm() == 0.0)
    return {SolveStatus::linear_solve_failed, "linear solve failed: " + lin.message};
  return {};
}

StaticSolver::Outcome StaticSolver::line_search(SolveState& st, double s) {
  // Energy line search on E(x) = U(x) - s f_ext^T x; dE/dx = -r, so the slope along dx is -r.dx.
  const double slope = st.r.dot(st.dx);
  if (!(slope > 0)) return {SolveStatus::line_search_failed, "Newton direction is not a descent direction"};
  {
    const auto t = Clock::now();
    if (!std::isfinite(st.energy)) st.energy = active_energy(st.model, st.x);
    st.report.force_ms += ms_since(t);
  }
  const Index na = matrix_.num_active();
  const std::vector<Index>& node_of_active = matrix_.node_of_active();
  double work = 0;  // s f_ext . dx
  for (Index a = 0; a < na; ++a)
    for (int c = 0; c < 3; ++c) work += s * st.load[node_of_active[a]][c] * st.dx[3 * a + c];
  double alpha = 1.0;
  st.step_length = 0;
  for (int cut = 0; cut < 30; ++cut) {
    st.x_trial = st.x;
    for (Index a = 0; a < na; ++a) {
      const Index v = node_of_active[a];
      for (int c = 0; c < 3; ++c)
        if (!held(st.anchors[v], c)) st.x_trial[v][c] += alpha * st.dx[3 * a + c];
    }
    const auto t = Clock::now();
    const double trial_energy = active_energy(st.model, st.x_trial);
    st.report.force_ms += ms_since(t);
    const double change = (trial_energy - st.energy) - alpha * work;
    // Round-off slack: energies of stiff materials at small strain carry ~1e-12 relative error.
    const double slack = 1e-9 * (std::abs(st.energy) + std::abs(trial_energy));
    if (std::isfinite(change) && change <= -kArmijo * alpha * slope + slack) {
      st.x.swap(st.x_trial);
      st.energy = trial_energy;
      st.step_length = alpha;
      return {};
    }
    if (!options_.line_search) break;
    alpha *= 0.5;
    ++st.report.line_search_cuts;
  }
  return {SolveStatus::line_search_failed, "line search found no energy decrease"};
}

Result<StaticReport> solve_static(const FemModel& model, const StaticProblem& problem, std::vector<Vec3>& x,
                                  const StaticSolverOptions& options) {
  StaticSolver solver(options);
  return solver.solve(model, problem, x);
}

}  // namespace shatter
