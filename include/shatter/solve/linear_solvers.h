// Linear solvers for Newton's system K dx = r on a BlockSparseMatrix (docs/method.md §2.3, the paper's
// §3.3): preconditioned conjugate gradients (3x3-block Jacobi, or symmetric block Gauss-Seidel) and
// a sparse LDL^T factorization in 3x3 blocks whose symbolic analysis is reused while the pattern
// stays the same.
#pragma once

#include <Eigen/Cholesky>

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/fem/assembly.h"
#include "shatter/solve/block_ldlt.h"

namespace shatter {

/// The linear solver used for Newton's system.
enum class LinearSolverKind {
  direct_ldlt,             ///< BlockLdlt (3x3 blocks, AMD ordering); the analysis once per pattern
  pcg_block_jacobi,        ///< CG preconditioned by the inverse 3x3 diagonal blocks
  pcg_block_gauss_seidel,  ///< CG preconditioned by one forward + one backward block Gauss-Seidel
                           ///< sweep (M = (D+L) D^-1 (D+U): symmetric positive definite)
  /// CG preconditioned by a two-level cycle: a forward block Gauss-Seidel sweep, a coarse
  /// correction in the rigid motions (3 translations, 3 rotations) of node aggregates, and a
  /// backward sweep. The sweeps remove the short-wavelength error, the coarse space the long
  /// one that they barely touch: the bending and drift of a body held at a few nodes (inertia
  /// relief) took Gauss-Seidel hundreds of iterations. Needs the node positions
  /// (LinearSolver::set_node_positions); without them the aggregates move only (no rotations).
  pcg_two_level,
};
/// "direct", "pcg-jacobi", "pcg-gauss-seidel" or "pcg-two-level".
const char* to_string(LinearSolverKind kind);
/// "direct", "pcg-jacobi", "pcg-gauss-seidel", "pcg-two-level" (as written by to_string).
Result<LinearSolverKind> parse_linear_solver_kind(std::string_view name);

/// Settings of a LinearSolver.
struct LinearSolverOptions {
  /// Default by measurement (docs/solver.md): on the anchored impact systems PCG with symmetric
  /// block Gauss-Seidel beats the factorization at a few hundred free DOFs and is 4-5x faster at
  /// a few thousand (3D fill-in makes the simplicial factorization slow).
  LinearSolverKind kind = LinearSolverKind::pcg_block_gauss_seidel;
  /// PCG stops when ||b - A x|| <= tol ||b||. The static solver loosens it per Newton iteration
  /// to what its own tolerance needs (inexact Newton), never below this value.
  double relative_tolerance = 1e-10;
  int max_iterations = 2000;  ///< PCG iteration limit
  /// PCG starts from the x passed in (the previous solution, when the caller keeps it) instead of
  /// from zero. The direct solver ignores it.
  bool warm_start = false;
  /// Direct solver: while the last factorization (of a positive definite matrix on the same
  /// pattern) is kept, first try CG preconditioned by it, to relative_tolerance, for at most the
  /// iterations that cost a quarter of a factorization; refactor only when that does not converge
  /// (after such failures in a row, the next 1, 2, 4, then 8 solves refactor without trying).
  /// Newton's matrices change little from one iteration to the next, and an impact's static solve
  /// refactored on every one.
  bool reuse_factorization = false;
  /// pcg_two_level: at most this many aggregates (the coarse system, 6 unknowns per aggregate, is
  /// factorized densely once per solve), each of at least min_aggregate_nodes nodes where the
  /// matrix has that many.
  int max_aggregates = 48;
  int min_aggregate_nodes = 32;
};

/// How one linear solve went.
struct LinearSolveReport {
  bool converged = false;        ///< within the tolerance (direct: factorization and solve succeeded)
  int iterations = 0;            ///< PCG iterations (0 for the direct solver)
  double relative_residual = 0;  ///< ||b - A x|| / ||b|| (0 when b = 0)
  double time_ms = 0;            ///< wall time of the whole solve, ms
  bool analyzed = false;         ///< direct: this call redid the symbolic analysis
  bool factorized = false;       ///< direct: this call factorized (else it reused the last factor)
  /// The matrix showed it is not positive definite: a diagonal block or a CG curvature p.Ap that
  /// is not positive, or a pivot of the factorization that is not. The direct solver still returns
  /// its (exact) solution then; PCG stops where it found out.
  bool indefinite = false;
  std::string message;  ///< why it did not converge ("" when it did)
};

/// What a direct solve of a pattern would cost (LinearSolver::direct_cost), from its symbolic
/// analysis: deterministic, unlike a time.
struct DirectCost {
  double factor_flops = 0;     ///< multiply-adds of the numeric factorization
  double factor_nonzeros = 0;  ///< nonzeros of L (a solve reads each twice)
};

/// A reusable solver: keeps the symbolic factorization (per pattern_id) and the work vectors.
class LinearSolver {
 public:
  /// A solver with `options` and no factorization yet.
  explicit LinearSolver(const LinearSolverOptions& options = {}) : options_(options) {}

  /// The current settings.
  [[nodiscard]] const LinearSolverOptions& options() const { return options_; }
  /// Change the settings (a kept symbolic analysis stays valid).
  void set_options(const LinearSolverOptions& options) { options_ = options; }

  /// Solve A x = b (b, x: a.size()). x is the initial guess when options().warm_start, else it is
  /// overwritten. Never leaves non-finite values in x: when the solve fails outright (bad b, failed
  /// factorization, a diagonal block not positive definite, a non-finite result) x is zero; PCG that
  /// stops early (iteration limit, CG breakdown) leaves its last iterate. converged is false then.
  LinearSolveReport solve(const BlockSparseMatrix& a, const Eigen::VectorXd& b, Eigen::VectorXd& x);

  /// The direct solver's cost on a's pattern; analyses the pattern if it is new (and keeps the
  /// analysis for a later direct solve).
  DirectCost direct_cost(const BlockSparseMatrix& a);

  /// Drop the kept numeric factorization (reuse_factorization), so that the next solves do not
  /// depend on what was solved before.
  void forget_factorization() {
    factored_pattern_ = 0;
    reuse_failures_ = 0;
    reuse_skip_ = 0;
  }

  /// Positions of the matrix's nodes (all of them, indexed like BlockSparseMatrix::num_nodes, m):
  /// the rigid motions of pcg_two_level's aggregates turn about them. Set them once per problem
  /// (the rest or current shape: the coarse space need only approximate the soft motions).
  void set_node_positions(std::vector<Vec3> positions) {
    node_positions_ = std::move(positions);
    aggregates_pattern_ = 0;
  }

  /// Aggregates of the last pcg_two_level solve (0 before one): at most max_aggregates.
  [[nodiscard]] Index num_aggregates() const { return num_aggregates_; }

  /// Symbolic analyses done so far (the direct solver does one per new pattern).
  [[nodiscard]] int symbolic_analyses() const { return symbolic_analyses_; }

 private:
  LinearSolveReport solve_direct(const BlockSparseMatrix& a, const Eigen::VectorXd& b, Eigen::VectorXd& x);
  LinearSolveReport solve_pcg(const BlockSparseMatrix& a, const Eigen::VectorXd& b, Eigen::VectorXd& x);
  bool invert_diagonal_blocks(const BlockSparseMatrix& a, std::string& message);
  void apply_preconditioner(const BlockSparseMatrix& a, const Eigen::VectorXd& r, Eigen::VectorXd& z);
  /// pcg_two_level: the aggregates of a's pattern (kept while the pattern and positions are), then
  /// the coarse matrix P^T A P of these values, factorized.
  void prepare_two_level(const BlockSparseMatrix& a);
  /// z = (D+L)^-1 r (forward block Gauss-Seidel sweep from zero).
  void forward_sweep(const BlockSparseMatrix& a, const Eigen::VectorXd& r, Eigen::VectorXd& z) const;
  /// z = (D+U)^-1 r (backward sweep from zero).
  void backward_sweep(const BlockSparseMatrix& a, const Eigen::VectorXd& r, Eigen::VectorXd& z) const;

  LinearSolverOptions options_;
  void analyze(const BlockSparseMatrix& a, LinearSolveReport* report);

  /// How a run of conjugate_gradients ended.
  struct CgEnd {
    int iterations = 0;
    double residual_norm = 0;  ///< ||r|| of the recurrence
    bool breakdown = false;    ///< p.Ap or r.z not positive
    bool indefinite = false;   ///< p.Ap not positive
  };
  /// Preconditioned CG on A x = b from r_ = b - A x (set by the caller) until ||r|| <= target or
  /// max_iterations; precondition(r, z) sets z = M^-1 r.
  template <class Precondition>
  CgEnd conjugate_gradients(const BlockSparseMatrix& a, Eigen::VectorXd& x, double target, int max_iterations,
                            Precondition&& precondition);
  /// CG preconditioned by the kept factorization (reuse_factorization); false when it did not
  /// converge within `max_iterations` (x is then undefined).
  bool solve_with_kept_factor(const BlockSparseMatrix& a, const Eigen::VectorXd& b, Eigen::VectorXd& x,
                              int max_iterations, LinearSolveReport& report);

  BlockLdlt ldlt_;
  std::uint64_t analyzed_pattern_ = 0;
  std::uint64_t factored_pattern_ = 0;  ///< pattern of a kept positive definite factorization (0: none)
  int reuse_failures_ = 0;              ///< reuse attempts that failed in a row
  int reuse_skip_ = 0;                  ///< direct solves left to factorize without an attempt
  int symbolic_analyses_ = 0;
  std::vector<Mat3> diagonal_inverse_;  ///< inverse diagonal blocks (#active)
  Eigen::VectorXd r_, z_, p_, q_;
  // pcg_two_level.
  std::vector<Vec3> node_positions_;      ///< set_node_positions (#nodes), or empty
  std::uint64_t aggregates_pattern_ = 0;  ///< pattern the aggregates below belong to (0: none)
  std::vector<Index> aggregate_of_;       ///< per active node
  /// Per active node, its offset from its aggregate's centre divided by the aggregate's radius
  /// (so that rotation and translation unknowns are of one scale).
  std::vector<Vec3> aggregate_offset_;
  std::vector<Vec3> free_component_;  ///< per active node: 1 for a free component, 0 for a held one
  Index num_aggregates_ = 0;
  int modes_ = 6;                       ///< unknowns per aggregate: 6, or 3 without positions
  Eigen::LLT<Eigen::MatrixXd> coarse_;  ///< P^T A P, factorized
  bool coarse_ok_ = false;              ///< it is positive definite (else: sweeps only)
  Eigen::VectorXd coarse_rhs_, sweep_, q_two_;
};

}  // namespace shatter
