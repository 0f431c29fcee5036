// Full FEM dynamics (docs/method.md §2.6, the paper's eq. 18-20): M a + C v + F(x) = f_ext with
// lumped masses, Rayleigh damping C = alpha M + beta K, integrated by implicit Euler. Each step
// minimises the incremental potential (docs/dynamics.md)
//   E(x) = 1/(2 h^2) |x - x_n - h v_n|_M^2 + alpha/(2h) |x - x_n|_M^2 + beta/(2h) (x - x_n)^T K_n (x - x_n)
//          + U(x) - m g . x + contact and friction potentials,
// whose stationary point is eq. 20 (K_n: the stiffness at the step's start, made positive
// semi-definite), by Newton with an energy line search on the static solver's assembly and linear
// solvers. For soft or small bodies; stiff bodies use the hybrid scheme (docs/impacts.md).
#pragma once

#include <span>
#include <string>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/types.h"
#include "shatter/fem/assembly.h"
#include "shatter/fem/fem_model.h"
#include "shatter/solve/linear_solvers.h"

namespace shatter {

/// A plane no node may cross: the side normal . x >= offset is outside (free).
struct ContactPlane {
  Vec3 normal = Vec3::UnitY();  ///< unit normal, pointing out of the obstacle
  double offset = 0;            ///< normal . x on the plane, m
  double friction = 0.5;        ///< Coulomb coefficient (static = dynamic), >= 0
};

/// One face plane of a convex obstacle: normal . x <= offset inside.
struct HalfSpace {
  Vec3 normal = Vec3::UnitX();  ///< outward unit normal
  double offset = 0;            ///< m
};

/// A convex obstacle that holds still during the step: the intersection of its faces' half-spaces
/// (a convex hull's faces in world coordinates, say). A node inside is pushed out through the face
/// it is least deep behind.
struct ContactConvex {
  std::vector<HalfSpace> faces;  ///< at least 4
  double friction = 0.5;         ///< Coulomb coefficient, >= 0
};

/// What the nodes collide with.
struct DynamicObstacles {
  std::vector<ContactPlane> planes;
  std::vector<ContactConvex> convexes;
};

/// Settings of DynamicSolver.
struct DynamicSolverOptions {
  double time_step = 1.0 / 60;       ///< h, s
  Vec3 gravity = Vec3(0, -9.81, 0);  ///< m/s^2
  double mass_damping = 0;           ///< Rayleigh alpha, 1/s
  double stiffness_damping = 0;      ///< Rayleigh beta, s
  /// Contact is a penalty k_i/2 d^2 on a node d deep in a plane, k_i = this * m_i / h^2: a node
  /// pressed by a load f sinks f / k_i (a body of mass m resting on n nodes: about m g h^2 / (n * this * m_i)).
  double contact_stiffness = 1e4;
  /// Friction is Coulomb's, smoothed below this sliding speed (m/s), with the normal force of the
  /// step's start (lagged, as in Li et al. 2020, "Incremental Potential Contact").
  double friction_speed = 1e-3;
  int max_newton_iterations = 50;  ///< per step
  /// Converged when the largest node move of a Newton step is at most this times h (m/s). A
  /// micrometre per second is far below anything that shows; 1e-9 cost about one Newton iteration
  /// in four more (soft_landing's mat: 2,851 against 2,158 linear solves), most of them only
  /// confirming a converged step.
  double velocity_tolerance = 1e-6;
  /// The linear solver of each Newton step. M/h^2 on the diagonal keeps the systems well
  /// conditioned, so PCG to 1e-6 beats the factorization 3-7x (bench_solve's BM_DynamicStep); the
  /// step size test above, not this tolerance, decides convergence.
  LinearSolverOptions linear = {.kind = LinearSolverKind::pcg_block_gauss_seidel, .relative_tolerance = 1e-6};
};

/// Positions and velocities of every node, m and m/s (#nodes each).
struct DynamicState {
  std::vector<Vec3> x;
  std::vector<Vec3> v;
};

/// How one step went.
struct DynamicStepReport {
  bool converged = false;     ///< the Newton step fell below the tolerance
  int newton_iterations = 0;  ///< this step
  int line_search_cuts = 0;   ///< step halvings
  int contacts = 0;           ///< node-obstacle pairs in contact at the end of the step
  double max_step = 0;        ///< the last Newton step's largest node move, m
  /// Per convex obstacle, what the body pushed it with over the step (contact and friction forces
  /// at the step's end times h): the impulse, N s, and its moment about the world origin, N m s
  /// (for an obstacle that is a rigid body: its angular impulse about its centre c is
  /// moment - c x impulse).
  std::vector<Vec3> convex_impulse, convex_moment;
  std::string message;  ///< why it did not converge ("" when it did)
};

/// Steps one FEM body; keeps the stiffness pattern and the linear solver's analysis between steps
/// (rebuilt when the model's tets change).
class DynamicSolver {
 public:
  /// A solver with `options` (checked at each step).
  explicit DynamicSolver(const DynamicSolverOptions& options = {});

  /// The current settings.
  [[nodiscard]] const DynamicSolverOptions& options() const { return options_; }

  /// Advances `state` by one time step against `obstacles`. Errors (state left as it was): state
  /// sizes that are not the model's node count, non-finite positions or velocities, bad options (a
  /// time step that is not positive and finite, negative damping, friction or stiffness) or
  /// obstacles (a normal that is not unit, a non-finite offset, a convex of fewer than 4 faces). A
  /// step that does not converge still moves the state to the last Newton iterate (never to
  /// non-finite values) and says so in the report.
  Result<DynamicStepReport> step(const FemModel& model, const DynamicObstacles& obstacles, DynamicState& state);

  /// Energy of a state, J: kinetic, elastic, gravitational (zero at the origin) and the contact
  /// penalty's. Implicit Euler never makes it grow (for a convex elastic energy; see
  /// docs/dynamics.md).
  [[nodiscard]] double energy(const FemModel& model, const DynamicObstacles& obstacles,
                              const DynamicState& state) const;

 private:
  DynamicSolverOptions options_;
  BlockSparseMatrix matrix_;
  std::vector<TetIndices> pattern_tets_;  ///< the tets matrix_'s pattern was built for
  LinearSolver linear_;
  ForceWorkspace workspace_;
};

}  // namespace shatter
