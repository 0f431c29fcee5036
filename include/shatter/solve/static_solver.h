// Static equilibrium F(x) = f_ext on the free nodes by Newton-Raphson (docs/method.md §2.3, the paper's
// eq. 14-17), with PSD-projected element stiffness, an energy line search and load stepping.
// StaticSolver keeps the sparse pattern and the symbolic factorization for repeated solves on the
// same mesh and anchors (the simulator solves at every impact).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fem/assembly.h"
#include "shatter/fem/fem_model.h"
#include "shatter/solve/linear_solvers.h"

namespace shatter {

/// Loads and boundary conditions of a static problem.
struct StaticProblem {
  /// Held components per node (#nodes; bit c = component c held); empty = nothing held.
  std::vector<AnchorMask> anchors;
  /// Prescribed positions of the held components, m (#nodes; only held components are read);
  /// empty = they keep their positions in the initial x.
  std::vector<Vec3> anchor_positions;
  /// External nodal forces, N (#nodes); empty = none.
  std::vector<Vec3> external_forces;
  /// Adds node_mass * gravity_vector to the external forces.
  bool gravity = false;
  Vec3 gravity_vector = Vec3(0, -9.81, 0);  ///< m/s^2
};

/// The stiffness matrix K of a Newton step (docs/solver.md).
enum class TangentKind {
  /// The exact K first; where the linear solve finds it indefinite (a diagonal block or a CG
  /// curvature that is not positive, a negative pivot of the factorization) or its step is not a
  /// descent direction or finds no energy decrease, the step is redone with the projected K
  /// ("project on demand", Longva et al. 2023, "Pitfalls of Projection").
  on_demand,
  /// Every element stiffness projected to positive semi-definite (AssemblyOptions::project_psd):
  /// always a descent direction, but convergence turns linear where compression is large.
  projected,
  /// The exact K only; a failure is the step's failure.
  exact,
  /// By the body's model, as impacts choose (docs/solver.md): projected for StVK, whose exact K
  /// softens under compression and whose exact steps follow the softening (a clay body dented by
  /// a blow tears); on_demand for the linear and corotated models, which do not soften.
  by_model,
};
/// The kind a solve of a `model` body uses for `kind` (by_model resolved; the others as given).
TangentKind resolve_tangent(TangentKind kind, ModelKind model);
/// "on-demand", "projected", "exact", "by-model".
const char* to_string(TangentKind kind);
/// The inverse of to_string (an error names the valid values).
Result<TangentKind> parse_tangent_kind(std::string_view name);

/// Iterations at or under this many make the next load step larger (StaticSolverOptions::load_increments).
inline constexpr int kEasyLoadStep = 4;
/// Iterations above this many make the next load step smaller.
inline constexpr int kHardLoadStep = 10;
/// Residual ratio of an assembled Newton step above which its convergence counts as linear, and
/// chord steps (StaticSolverOptions::chord_tolerance) may take over.
inline constexpr double kChordLinearRate = 0.1;
/// Cost of a chord step with the direct solver (forces, energies and a triangular solve) as a
/// fraction of an assembled one (also a refill and a factorization). Measured about 0.2 in the clay
/// teddy's impact solves (0.1-0.15 ms against 0.7 ms); 0.25 errs toward assembling.
inline constexpr double kChordCost = 0.25;
/// PCG iterations of one Newton step from which StaticSolverOptions::direct_when_cheaper weighs a
/// factorization.
inline constexpr int kMinIterationsForDirect = 50;
/// PCG iterations with the two-level preconditioner that StaticSolverOptions::direct_when_cheaper
/// expects per Newton step (measured: 13-26 on the cinder blocks' impact systems, held far away or
/// by inertia relief).
inline constexpr int kTwoLevelIterations = 30;

/// Settings of the Newton solver.
struct StaticSolverOptions {
  int max_newton_iterations = 20;  ///< per load step
  /// Converged when ||f_ext - F(x)|| over the free components <= tol * reference, reference =
  /// ||f_ext|| over the free components (or, with no load, the initial imbalance that the
  /// prescribed anchor positions cause). Where round-off keeps the residual above that (stiff
  /// bodies, tight tolerances), a residual within its estimated round-off that a Newton step no
  /// longer reduces counts as converged.
  /// The default resolves displacements to about 1e-7 of their largest (the CalculiX comparison);
  /// Newton's quadratic convergence makes it cost about one iteration more than 1e-6.
  double relative_residual_tolerance = 1e-8;
  /// The largest relative residual the round-off rule above may accept under an external load.
  /// Above it the round-off is itself the error (a mesh far from the origin: at x = 1e7 m a glass bar's displacements are
  /// below the spacing of the doubles, and the residual stalls near 1), and the solve ends
  /// not converged instead of reporting a wrong answer as converged.
  double max_round_off_residual = 1e-3;
  /// Backtracking (Armijo) on the potential energy U(x) - f_ext^T x. Without it a step is only
  /// tried at full length (and still rejected when the energy rises or turns non-finite).
  bool line_search = true;
  /// Which stiffness Newton solves with (TangentKind). The default, on_demand, keeps quadratic
  /// convergence wherever the exact stiffness is positive definite and the robustness of the
  /// projected one elsewhere.
  TangentKind tangent = TangentKind::on_demand;
  /// The first load step is 1 / load_increments of the load. Later steps adapt: a step that
  /// converged in at most kEasyLoadStep Newton iterations lets the next grow by half, one that took
  /// more than kHardLoadStep shrinks it by a quarter (as CalculiX does), and a failed step is
  /// retried at half its size.
  int load_increments = 1;
  /// A load step that fails (energy cannot decrease, non-finite values, no convergence) is
  /// retried at half the size, at most this many times in the whole solve.
  int max_load_halvings = 8;
  /// Newton iterations over the whole solve, all load steps together (0: no limit). When they run
  /// out the solve ends at the last load fraction in equilibrium, as when the halvings do: a bound
  /// on the time of a solve whose load steps each converge, but slowly (a large deformation met
  /// in many small load steps).
  int max_total_newton_iterations = 0;
  /// End a load step early (as failed: it is retried at half the size) when, from the last four
  /// iterations, the residual falls too slowly to meet the tolerance in twice the iterations left
  /// (or does not fall), as CalculiX cuts an increment back on the predicted iterations. Off by
  /// default; impact solves use it: their hard steps (a clay body crushed past what StVK carries)
  /// otherwise spent their whole 12 iterations before failing.
  bool abandon_slow_load_steps = false;
  /// Bracketing of the largest load in equilibrium, as a fraction of the full load (0: off). Once
  /// a load step has failed, its fraction bounds the search from above: a later step reaches it
  /// again only when that step is at most a quarter of the one that failed there (a retry from
  /// much closer; otherwise the step stops three quarters of the way), and the solve ends at the
  /// fraction reached, reported as not converged as when the halvings run out, rather than take a
  /// step smaller than this that stays below a failed fraction. A body past its limit load (a clay
  /// body crushed past what StVK carries) then spends no iterations closing in on that limit
  /// beyond this resolution, while a body that only needs smaller steps still reaches the full
  /// load. A failed step whose residual fell under intermediate_tolerance failed on the
  /// tolerance, not for want of an equilibrium, and bounds nothing; at the full load it ends the
  /// solve there, not converged, instead of being retried from below. Impact solves use 1/8
  /// (docs/solver.md, "Bracketing a limit load").
  double limit_resolution = 0;
  /// Load steps before the last need only this relative residual: they only give the next step
  /// its start, and Newton's quadratic convergence at the last step makes up for it in one or two
  /// iterations. Never tighter than relative_residual_tolerance.
  double intermediate_tolerance = 1e-3;
  /// Keep one record per Newton iteration in StaticReport::history.
  bool record_history = true;
  /// With an iterative linear solver: when a Newton step's PCG took at least
  /// kMinIterationsForDirect iterations (an ill-conditioned system: slender parts, soft materials,
  /// a body held at a few nodes), weigh going on against a factorization (its cost from the
  /// symbolic analysis) and against PCG with the two-level preconditioner (pcg_two_level), by
  /// multiply-adds (deterministic), and use the cheapest for the rest of the solves on this pattern.
  bool direct_when_cheaper = true;
  /// The caller knows the system is ill-conditioned (a body held at three nodes by inertia relief):
  /// direct_when_cheaper chooses between the factorization and the two-level PCG at the first Newton
  /// step without first running kMinIterationsForDirect Gauss-Seidel PCG iterations to find out.
  bool ill_conditioned = false;
  /// Near the solution (relative residual below this), a Newton step reuses the last tangent it
  /// assembled, and with the direct solver its factorization, instead of assembling a new one (a
  /// chord step), for as long as each such step cuts the residual at least tenfold. Each step is
  /// cheaper, the convergence linear instead of quadratic: for solves that need one or two steps
  /// near the solution (impacts: 1e-2). With the direct solver, chord steps also take over at any
  /// residual where assembled steps converge only linearly (kChordLinearRate), for as long as they
  /// converge about as fast per unit of cost (kChordCost) and can meet the load step's tolerance
  /// within its iterations left. 0: always assemble.
  double chord_tolerance = 0;
  /// PCG: the first Newton step of a load step starts from the previous first step d, scaled by
  /// (r.d)/(d.K d) (the energy-norm optimal multiple: never a worse start than zero). Repeated
  /// impacts at one place with other magnitudes then need few iterations.
  bool warm_start = true;
  /// The linear solver of each Newton step. Its relative_tolerance is a floor (the Newton solver
  /// loosens it as its own tolerance allows); its warm_start is replaced by the one above.
  LinearSolverOptions linear;
};

/// How a static solve ended (StaticReport::status). Every failure happens in a load step, which is
/// retried at half the size (StaticSolverOptions::max_load_halvings); when the halvings run out the
/// report carries the status of that last failure, not a separate "load step failed": the reason
/// is what a caller can act on, and load_fraction < 1 with the message already says that load
/// stepping gave up (and at which fraction).
enum class SolveStatus {
  converged,  ///< equilibrium within the tolerance (or at round-off level) at the full load
  /// Rejected before any iteration, x left as passed in: a non-finite initial position, force,
  /// anchor position, gravity or total load, invalid Lame constants, or a degenerate rest tet.
  invalid_input,
  /// Internal forces turned non-finite (overflow): at the prescribed anchor positions (x is then the
  /// initial x) or during a load step.
  not_finite,
  no_convergence,  ///< max_newton_iterations reached without meeting the tolerance
  /// The Newton step cannot lower the energy: not a descent direction (possible without PSD
  /// projection), or no step length along it does.
  line_search_failed,
  /// The linear solve gave no usable step: a failed factorization, or a non-finite or zero step.
  linear_solve_failed,
};
/// "converged", "invalid-input", "not-finite", "no-convergence", "line-search-failed",
/// "linear-solve-failed".
const char* to_string(SolveStatus status);

/// One Newton iteration of a solve (StaticReport::history).
struct NewtonIteration {
  double load_fraction = 0;      ///< of the load step it belongs to
  double relative_residual = 0;  ///< before the step, against the full load's reference
  double step_length = 0;        ///< the line search's accepted fraction of the Newton step (0: none)
  bool projected = false;        ///< solved with the projected stiffness
  bool direct = false;           ///< solved with the direct linear solver
  int linear_iterations = 0;     ///< PCG iterations (0 for the direct solver), all tries together
};

/// How a static solve went.
struct StaticReport {
  bool converged = false;           ///< status == SolveStatus::converged
  int newton_iterations = 0;        ///< Newton iterations over all load steps
  double relative_residual = 0;     ///< at the returned x, as in the tolerance
  int load_steps = 0;               ///< load steps completed
  double load_fraction = 0;         ///< fraction of the load in equilibrium at the returned x
  int linear_iterations_total = 0;  ///< PCG iterations over all Newton iterations
  int line_search_cuts = 0;         ///< step halvings by the line search
  int projected_iterations = 0;     ///< Newton iterations that used the projected stiffness
  int direct_iterations = 0;        ///< Newton iterations solved with the direct solver
  int chord_iterations = 0;         ///< Newton iterations with the last tangent (chord_tolerance)
  int load_step_failures = 0;       ///< load steps retried at half the size
  /// Every Newton iteration, then one last entry with the final residual (step_length 0), when
  /// StaticSolverOptions::record_history.
  std::vector<NewtonIteration> history;
  double assembly_ms = 0;                            ///< stiffness refills (and the pattern when built), ms
  double linear_solve_ms = 0;                        ///< linear solves (factorizations, PCG), ms
  double force_ms = 0;                               ///< internal forces and energies, ms
  double total_ms = 0;                               ///< the whole solve, ms
  SolveStatus status = SolveStatus::no_convergence;  ///< how it ended (a default report has not converged)
  std::string message;                               ///< why it did not converge ("" when it did)
};

/// Keeps what can be reused between solves with the same tets and anchors.
class StaticSolver {
 public:
  /// A solver with `options` and no pattern yet.
  explicit StaticSolver(const StaticSolverOptions& options = {});

  /// The current settings.
  [[nodiscard]] const StaticSolverOptions& options() const { return options_; }
  /// Change the settings (the kept pattern and symbolic analysis stay).
  void set_options(const StaticSolverOptions& options);

  /// x: initial guess (usually the rest positions), m (#nodes); receives the solution. Returns an
  /// error for inconsistent sizes; numerical trouble (non-finite input, no convergence) gives a
  /// report with converged = false, a status and a message, and x then holds the last equilibrium
  /// reached (at a fraction of the load; at worst the initial x with the anchors applied), never NaN.
  Result<StaticReport> solve(const FemModel& model, const StaticProblem& problem, std::vector<Vec3>& x);

  /// Times the sparse pattern was (re)built; stays put while tets and anchors do not change.
  [[nodiscard]] int pattern_builds() const { return pattern_builds_; }
  /// The linear solver (symbolic analyses done so far).
  [[nodiscard]] const LinearSolver& linear_solver() const { return linear_; }
  /// The stiffness of the last Newton iteration (empty before the first solve).
  [[nodiscard]] const BlockSparseMatrix& matrix() const { return matrix_; }

 private:
  struct Outcome;     ///< how a step of a solve ended: status and message (static_solver.cpp)
  struct SolveState;  ///< what one solve() call shares between its steps (static_solver.cpp)

  /// Non-finite input, invalid material, degenerate rest tets: invalid_input, or converged to go on.
  static Outcome check_inputs(const SolveState& st);
  /// Sparse pattern, full load, residual reference. A value ends the solve with that outcome (bad
  /// load, or already in equilibrium); nullopt goes on to the load steps.
  std::optional<Outcome> prepare(SolveState& st);
  /// The reference that relative residuals divide by (part of prepare; same return convention).
  std::optional<Outcome> set_reference(SolveState& st);
  /// st.r = s f_ext - F(x) on the free components (0 on held ones) at load fraction s, and
  /// st.round_off; returns ||st.r||, N.
  double residual(SolveState& st, double s);
  /// Newton iterations at load fraction s from the current x until the relative residual is at
  /// most `tolerance`: converged, or why not. `iterations` receives the Newton iterations taken.
  Outcome newton_load_step(SolveState& st, double s, double tolerance, int& iterations);
  /// One Newton iteration at load fraction s: direction (exact or projected stiffness, by
  /// options().tangent) and line search.
  Outcome newton_iteration(SolveState& st, double s, int iteration, double relative_residual);
  /// Assembles K at x and solves K dx = r (inexactly with PCG) into st.dx; `projected` picks the
  /// projected stiffness. `indefinite` is set when the solve found K not positive definite.
  Outcome newton_direction(SolveState& st, int iteration, double relative_residual, bool projected, bool& indefinite);
  /// The last history entry: the residual at the returned x.
  void record_final(SolveState& st) const;
  /// Backtracking on the energy along st.dx; moves x to the accepted point.
  Outcome line_search(SolveState& st, double s);

  void update_pattern(const FemModel& model, const std::vector<AnchorMask>& anchors);
  /// Internal forces of the active tets at x, summed into force_ (taken from the last
  /// active_energy when that was at the same x).
  void active_forces(const FemModel& model, const std::vector<Vec3>& x);
  /// Strain energy of the active tets at x, J. Finds their forces at x on the way (trial_*).
  double active_energy(const FemModel& model, const std::vector<Vec3>& x);
  /// Forces, their round-off bound and (corotated) F's polar decomposition of active tet slot s at
  /// x, into tet_force_[s], tet_force_error_[s] and polar[tet]; the tet's energy, J.
  double tet_forces(const FemModel& model, const std::vector<Vec3>& x, std::size_t s, std::vector<Mat34>& force,
                    std::vector<double>& error, std::vector<Polar>& polar) const;

  StaticSolverOptions options_;
  BlockSparseMatrix matrix_;
  std::vector<TetIndices> pattern_tets_;
  std::vector<AnchorMask> pattern_anchors_;
  bool has_pattern_ = false;
  int pattern_builds_ = 0;
  LinearSolver linear_;
  std::vector<Vec3> force_;              ///< internal forces, N (#nodes; valid on active tets' nodes)
  std::vector<Mat34> tet_force_;         ///< forces per active tet, N (#active tets)
  std::vector<double> force_error_;      ///< squared round-off estimate per component of force_, N^2 (#nodes)
  std::vector<double> tet_force_error_;  ///< round-off estimate per force component per active tet, N
  /// Corotated models: the polar decomposition of each active tet's F where tet_force_ was found,
  /// which the stiffness refill there reads (#tets, by tet).
  std::vector<Polar> tet_polar_;
  std::vector<Vec3> forces_at_;  ///< positions tet_force_ and tet_polar_ belong to, m (empty: none)
  /// The same found by the last active_energy (a line-search trial): taken over by active_forces
  /// when the trial is accepted, since the next residual is at that x.
  std::vector<Mat34> trial_force_;
  std::vector<double> trial_force_error_;
  std::vector<Polar> trial_polar_;
  std::vector<Vec3> trial_at_;
  Eigen::VectorXd first_step_;     ///< first Newton step of the last load step (#DOFs)
  bool direct_checked_ = false;    ///< direct_when_cheaper weighed the factorization for this pattern
  bool prefer_direct_ = false;     ///< ... and found it cheaper than PCG
  bool prefer_two_level_ = false;  ///< ... or found PCG with the two-level preconditioner cheapest
  // The weighing's estimates, in multiply-adds: a factorization and solve, going on with PCG, the
  // two-level preconditioner's set-up per solve and its cost per iteration.
  double direct_cost_ = 0;
  double pcg_cost_ = 0;
  double two_level_setup_ = 0;
  double two_level_iteration_ = 0;
};

/// One-off solve (builds a StaticSolver).
Result<StaticReport> solve_static(const FemModel& model, const StaticProblem& problem, std::vector<Vec3>& x,
                                  const StaticSolverOptions& options = {});

}  // namespace shatter
