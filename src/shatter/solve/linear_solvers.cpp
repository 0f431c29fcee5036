// PCG with block preconditioners and the reusable sparse LDL^T solver.
#include "shatter/solve/linear_solvers.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "shatter/core/clock.h"

namespace shatter {

namespace {

bool all_finite(const Eigen::VectorXd& v) { return v.allFinite(); }

}  // namespace

const char* to_string(LinearSolverKind kind) {
  switch (kind) {
    case LinearSolverKind::direct_ldlt: return "direct";
    case LinearSolverKind::pcg_block_jacobi: return "pcg-jacobi";
    case LinearSolverKind::pcg_block_gauss_seidel: return "pcg-gauss-seidel";
    case LinearSolverKind::pcg_two_level: return "pcg-two-level";
  }
  return "?";
}

Result<LinearSolverKind> parse_linear_solver_kind(std::string_view name) {
  for (LinearSolverKind k : {LinearSolverKind::direct_ldlt, LinearSolverKind::pcg_block_jacobi,
                             LinearSolverKind::pcg_block_gauss_seidel, LinearSolverKind::pcg_two_level})
    if (name == to_string(k)) return k;
  return field_error("linear_solver", "unknown linear solver '" + std::string(name) +
                                          "'; expected direct, pcg-jacobi, pcg-gauss-seidel or pcg-two-level");
}

LinearSolveReport LinearSolver::solve(const BlockSparseMatrix& a, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  const auto start = Clock::now();
  LinearSolveReport report;
  if (b.size() != a.size()) {
    x.setZero(a.size());
    report.message = "right-hand side has the wrong size";
  } else if (!all_finite(b)) {
    x.setZero(a.size());
    report.message = "right-hand side is not finite";
  } else if (a.size() == 0 || b.squaredNorm() == 0.0) {
    x.setZero(a.size());
    report.converged = true;
  } else if (options_.kind == LinearSolverKind::direct_ldlt) {
    report = solve_direct(a, b, x);
  } else {
    report = solve_pcg(a, b, x);
  }
  if (!all_finite(x)) {
    x.setZero(a.size());
    report.converged = false;
    if (report.message.empty()) report.message = "solution is not finite";
  }
  report.time_ms = ms_since(start);
  return report;
}

void LinearSolver::analyze(const BlockSparseMatrix& a, LinearSolveReport* report) {
  // The ordering and elimination tree depend only on the pattern: analyse once per pattern.
  if (analyzed_pattern_ == a.pattern_id()) return;
  ldlt_.analyze(a);
  analyzed_pattern_ = a.pattern_id();
  factored_pattern_ = 0;  // the analysis drops the numeric factorization
  ++symbolic_analyses_;
  if (report != nullptr) report->analyzed = true;
}

DirectCost LinearSolver::direct_cost(const BlockSparseMatrix& a) {
  analyze(a, nullptr);
  return {.factor_flops = ldlt_.factor_flops(), .factor_nonzeros = ldlt_.factor_nonzeros()};
}

template <class Precondition>
LinearSolver::CgEnd LinearSolver::conjugate_gradients(const BlockSparseMatrix& a, Eigen::VectorXd& x, double target,
                                                      int max_iterations, Precondition&& precondition) {
  CgEnd end;
  double r_norm = r_.norm();
  precondition(r_, z_);
  p_ = z_;
  double rz = r_.dot(z_);
  while (r_norm > target && end.iterations < max_iterations) {
    a.multiply(p_, q_);
    const double pq = p_.dot(q_);
    if (!(pq > 0.0) || !(rz > 0.0)) {
      end.breakdown = true;
      end.indefinite = !(pq > 0.0);
      break;
    }
    const double alpha = rz / pq;
    x.noalias() += alpha * p_;
    r_.noalias() -= alpha * q_;
    r_norm = r_.norm();
    ++end.iterations;
    if (r_norm <= target) break;
    precondition(r_, z_);
    const double rz_new = r_.dot(z_);
    p_ = z_ + (rz_new / rz) * p_;
    rz = rz_new;
  }
  end.residual_norm = r_norm;
  return end;
}

bool LinearSolver::solve_with_kept_factor(const BlockSparseMatrix& a, const Eigen::VectorXd& b, Eigen::VectorXd& x,
                                          int max_iterations, LinearSolveReport& report) {
  const double target = options_.relative_tolerance * b.norm();
  x.setZero(a.size());
  r_ = b;
  const CgEnd end = conjugate_gradients(a, x, target, max_iterations,
                                        [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { ldlt_.solve(r, z); });
  // A breakdown is left to the factorization to decide (and report).
  if (end.breakdown || !(end.residual_norm <= target) || !all_finite(x)) return false;
  report.iterations = end.iterations;
  return true;
}

LinearSolveReport LinearSolver::solve_direct(const BlockSparseMatrix& a, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  LinearSolveReport report;
  analyze(a, &report);
  if (options_.reuse_factorization && factored_pattern_ == a.pattern_id()) {
    // After attempts that failed in a row (matrices that change a lot between solves), the next
    // 1, 2, 4 or 8 solves factorize without one.
    if (reuse_skip_ > 0) {
      --reuse_skip_;
    } else {
      // A CG iteration reads L twice and A once; a factorization does about factor_flops
      // multiply-adds.
      const double iteration_cost = 4.0 * ldlt_.factor_nonzeros() + 2.0 * a.num_values() + 10.0 * a.size();
      const int budget = static_cast<int>(std::clamp(0.25 * ldlt_.factor_flops() / iteration_cost, 2.0, 30.0));
      if (solve_with_kept_factor(a, b, x, budget, report)) {
        reuse_failures_ = 0;
        a.multiply(x, q_);
        report.relative_residual = (b - q_).norm() / b.norm();
        report.converged = true;
        return report;
      }
      reuse_skip_ = 1 << std::min(reuse_failures_, 3);
      ++reuse_failures_;
    }
  }
  factored_pattern_ = 0;
  const bool factored = ldlt_.factorize(a);
  report.factorized = true;
  report.iterations = 0;
  if (!factored) {
    x.setZero(a.size());
    report.message = "sparse LDL^T factorization failed (singular matrix: is the body anchored?)";
    return report;
  }
  report.indefinite = !ldlt_.positive_definite();
  if (!report.indefinite) factored_pattern_ = a.pattern_id();
  ldlt_.solve(b, x);
  if (!all_finite(x)) {
    x.setZero(a.size());
    report.message = "sparse LDL^T solve gave non-finite values (singular matrix)";
    return report;
  }
  Eigen::VectorXd ax;
  a.multiply(x, ax);
  report.relative_residual = (b - ax).norm() / b.norm();
  report.converged = true;
  return report;
}

bool LinearSolver::invert_diagonal_blocks(const BlockSparseMatrix& a, std::string& message) {
  diagonal_inverse_.resize(static_cast<std::size_t>(a.num_active()));
  for (Index i = 0; i < a.num_active(); ++i) {
    const Mat3 d = a.block(i, a.diagonal_block(i));
    Mat3 inv;
    bool invertible = false;
    d.computeInverseWithCheck(inv, invertible, 0.0);
    if (!invertible || !inv.allFinite() || d.determinant() <= 0.0) {
      message = "diagonal block of node " + std::to_string(a.node_of_active()[i]) + " is not positive definite";
      return false;
    }
    diagonal_inverse_[i] = inv;
  }
  return true;
}

namespace {

// Sum over the blocks k in [k_begin, k_end) of block row i of A: A_ik z_col(k). The three rows
// in one pass (three independent chains of additions), each summed in block order.
Vec3 row_product(const BlockSparseMatrix& a, const Eigen::VectorXd& z, Index i, Index k_begin, Index k_end) {
  const std::vector<Index>& ptr = a.block_ptr();
  const std::vector<Index>& col = a.block_col();
  const Index p0 = ptr[i];
  const Index stride = 3 * (ptr[i + 1] - p0);
  const double* v0 = a.values() + 9 * p0;
  const double* v1 = v0 + stride;
  const double* v2 = v1 + stride;
  double acc0 = 0, acc1 = 0, acc2 = 0;
  for (Index k = k_begin; k < k_end; ++k) {
    const Index o = 3 * (k - p0);
    const Index c = 3 * col[k];
    const double z0 = z[c], z1 = z[c + 1], z2 = z[c + 2];
    acc0 += v0[o] * z0 + v0[o + 1] * z1 + v0[o + 2] * z2;
    acc1 += v1[o] * z0 + v1[o + 1] * z1 + v1[o + 2] * z2;
    acc2 += v2[o] * z0 + v2[o + 1] * z1 + v2[o + 2] * z2;
  }
  return {acc0, acc1, acc2};
}

// [d]x: the matrix of the cross product d x (.).
Mat3 cross_matrix(const Vec3& d) {
  Mat3 m;
  m << 0, -d.z(), d.y(), d.z(), 0, -d.x(), -d.y(), d.x(), 0;
  return m;
}

}  // namespace

void LinearSolver::forward_sweep(const BlockSparseMatrix& a, const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
  z.resize(a.size());
  const std::vector<Index>& ptr = a.block_ptr();
  for (Index i = 0; i < a.num_active(); ++i) {
    const Vec3 s = r.segment<3>(3 * i) - row_product(a, z, i, ptr[i], a.diagonal_block(i));
    z.segment<3>(3 * i) = diagonal_inverse_[i] * s;
  }
}

void LinearSolver::backward_sweep(const BlockSparseMatrix& a, const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
  z.resize(a.size());
  const std::vector<Index>& ptr = a.block_ptr();
  for (Index i = a.num_active() - 1; i >= 0; --i) {
    const Vec3 s = r.segment<3>(3 * i) - row_product(a, z, i, a.diagonal_block(i) + 1, ptr[i + 1]);
    z.segment<3>(3 * i) = diagonal_inverse_[i] * s;
  }
}

void LinearSolver::prepare_two_level(const BlockSparseMatrix& a) {
  const Index na = a.num_active();
  const std::vector<Index>& ptr = a.block_ptr();
  const std::vector<Index>& col = a.block_col();
  if (aggregates_pattern_ != a.pattern_id()) {
    // Aggregates grown breadth-first over the matrix graph from the lowest unassigned node, each
    // to `size` nodes (connected pieces of the body, in a fixed order). A piece that ran out of
    // unassigned neighbours below a quarter of that joins the aggregate of a neighbour.
    const Index size =
        std::max<Index>(std::max(1, options_.min_aggregate_nodes),
                        (na + std::max(1, options_.max_aggregates) - 1) / std::max(1, options_.max_aggregates));
    aggregate_of_.assign(static_cast<std::size_t>(na), -1);
    std::vector<Index> queue;
    Index count = 0;
    for (Index seed = 0; seed < na; ++seed) {
      if (aggregate_of_[seed] >= 0) continue;
      queue.assign(1, seed);
      aggregate_of_[seed] = count;
      for (std::size_t head = 0; head < queue.size() && static_cast<Index>(queue.size()) < size; ++head)
        for (Index k = ptr[queue[head]]; k < ptr[queue[head] + 1] && static_cast<Index>(queue.size()) < size; ++k)
          if (aggregate_of_[col[k]] < 0) {
            aggregate_of_[col[k]] = count;
            queue.push_back(col[k]);
          }
      Index join = -1;
      if (4 * static_cast<Index>(queue.size()) < size)
        for (std::size_t q = 0; q < queue.size() && join < 0; ++q)
          for (Index k = ptr[queue[q]]; k < ptr[queue[q] + 1]; ++k)
            if (aggregate_of_[col[k]] >= 0 && aggregate_of_[col[k]] != count) {
              join = aggregate_of_[col[k]];
              break;
            }
      if (join >= 0) {
        for (Index v : queue) aggregate_of_[v] = join;
      } else {
        ++count;
      }
    }
    // Pieces squeezed between earlier aggregates can leave more than max_aggregates (each coarse
    // unknown costs the dense factorization dearly): pair each aggregate with its first unpaired
    // neighbour, in node order, until few enough remain or none can pair.
    const Index max_count = std::max(1, options_.max_aggregates);
    while (count > max_count) {
      std::vector<Index> partner(static_cast<std::size_t>(count), -1);
      for (Index i = 0; i < na; ++i) {
        const Index g = aggregate_of_[i];
        if (partner[g] >= 0) continue;
        for (Index k = ptr[i]; k < ptr[i + 1]; ++k) {
          const Index h = aggregate_of_[col[k]];
          if (h != g && partner[h] < 0) {
            partner[g] = g;
            partner[h] = g;
            break;
          }
        }
      }
      std::vector<Index> renumber(static_cast<std::size_t>(count), -1);
      Index next = 0;
      for (Index g = 0; g < count; ++g) {
        const Index pair = partner[g] >= 0 ? partner[g] : g;
        if (renumber[pair] < 0) renumber[pair] = next++;
        renumber[g] = renumber[pair];
      }
      if (next == count) break;
      for (Index i = 0; i < na; ++i) aggregate_of_[i] = renumber[aggregate_of_[i]];
      count = next;
    }
    num_aggregates_ = count;
    // Offsets from each aggregate's centre, in units of its radius.
    const bool have_positions = static_cast<Index>(node_positions_.size()) == a.num_nodes();
    modes_ = have_positions ? 6 : 3;
    aggregate_offset_.assign(static_cast<std::size_t>(na), Vec3::Zero());
    if (have_positions) {
      std::vector<Vec3> centre(static_cast<std::size_t>(count), Vec3::Zero());
      std::vector<double> nodes(static_cast<std::size_t>(count), 0.0), radius2(static_cast<std::size_t>(count), 0.0);
      for (Index i = 0; i < na; ++i) {
        centre[aggregate_of_[i]] += node_positions_[a.node_of_active()[i]];
        nodes[aggregate_of_[i]] += 1;
      }
      for (Index g = 0; g < count; ++g) centre[g] /= nodes[g];
      std::vector<Mat3> scatter(static_cast<std::size_t>(count), Mat3::Zero());
      for (Index i = 0; i < na; ++i) {
        const Index g = aggregate_of_[i];
        aggregate_offset_[i] = node_positions_[a.node_of_active()[i]] - centre[g];
        radius2[g] += aggregate_offset_[i].squaredNorm();
        scatter[g] += aggregate_offset_[i] * aggregate_offset_[i].transpose();
      }
      // An aggregate of fewer than four nodes (a small piece of the graph on its own), or of
      // nodes on one line, only moves: a rotation about that line would move none of them, and
      // a coarse matrix singular along it would amplify round-off. Its zero rotation unknowns are
      // set apart below.
      std::vector<char> rotates(static_cast<std::size_t>(count), 0);
      for (Index g = 0; g < count; ++g) {
        if (nodes[g] < 4 || !(radius2[g] > 0)) continue;
        Eigen::SelfAdjointEigenSolver<Mat3> eig;
        eig.computeDirect(scatter[g], Eigen::EigenvaluesOnly);
        rotates[g] = eig.eigenvalues()[1] > 1e-6 * eig.eigenvalues()[2];
      }
      for (Index i = 0; i < na; ++i) {
        const Index g = aggregate_of_[i];
        aggregate_offset_[i] =
            rotates[g] ? Vec3(aggregate_offset_[i] / std::sqrt(radius2[g] / nodes[g])) : Vec3::Zero();
      }
    }
    // A held component of a partly held node stays 0: the coarse motions leave it out.
    free_component_.resize(static_cast<std::size_t>(na));
    for (Index i = 0; i < na; ++i)
      for (int c = 0; c < 3; ++c) free_component_[i][c] = held(a.anchors()[a.node_of_active()[i]], c) ? 0.0 : 1.0;
    aggregates_pattern_ = a.pattern_id();
  }
  // P^T A P. Node i of aggregate g moves by P_i e_g = F_i (t - S_i w) for the aggregate's
  // translation t and rotation w, with S_i = [d_i]x (d_i the node's scaled offset) and F_i the
  // diagonal of its free components. With B = F_i A_ij F_j, block (g, h) gathers
  // P_i^T A_ij P_j = [B, -B S_j; S_i B, -S_i B S_j] (S_i^T = -S_i).
  const Index nc = modes_ * num_aggregates_;
  Eigen::MatrixXd coarse = Eigen::MatrixXd::Zero(nc, nc);
  for (Index i = 0; i < na; ++i) {
    const Index g = aggregate_of_[i];
    const Mat3 si = cross_matrix(aggregate_offset_[i]);
    for (Index k = ptr[i]; k < ptr[i + 1]; ++k) {
      const Index j = col[k];
      const Index h = aggregate_of_[j];
      const Mat3 b = free_component_[i].asDiagonal() * a.block(i, k) * free_component_[j].asDiagonal();
      coarse.block<3, 3>(modes_ * g, modes_ * h) += b;
      if (modes_ == 3) continue;
      const Mat3 sj = cross_matrix(aggregate_offset_[j]);
      const Mat3 bs = b * sj;
      coarse.block<3, 3>(6 * g, 6 * h + 3) -= bs;
      coarse.block<3, 3>(6 * g + 3, 6 * h) += si * b;
      coarse.block<3, 3>(6 * g + 3, 6 * h + 3) -= si * bs;
    }
  }
  for (Index c = 0; c < nc; ++c)
    if (coarse(c, c) == 0.0) coarse(c, c) = 1.0;  // an unknown no node moves with: solved as 0
  coarse_.compute(coarse);
  coarse_ok_ = coarse_.info() == Eigen::Success;
}

void LinearSolver::apply_preconditioner(const BlockSparseMatrix& a, const Eigen::VectorXd& r, Eigen::VectorXd& z) {
  const Index na = a.num_active();
  z.resize(a.size());
  if (options_.kind == LinearSolverKind::pcg_block_jacobi) {
    parallel_for(
        0, na, [&](std::int64_t i) { z.segment<3>(3 * i) = diagonal_inverse_[i] * r.segment<3>(3 * i); },
        16384);  // ~0.01 us per block, once per PCG iteration
    return;
  }
  if (options_.kind == LinearSolverKind::pcg_two_level && coarse_ok_) {
    // z = B r for the two-level cycle: a forward sweep, the coarse correction of what it left,
    // a backward sweep. With the sweeps each other's transposes and an exact coarse solve, B is
    // symmetric positive definite, as CG needs.
    forward_sweep(a, r, z);
    a.multiply(z, sweep_);
    sweep_ = r - sweep_;
    coarse_rhs_.setZero(modes_ * num_aggregates_);
    for (Index i = 0; i < na; ++i) {
      const Index g = aggregate_of_[i];
      const Vec3 t = free_component_[i].cwiseProduct(sweep_.segment<3>(3 * i));
      coarse_rhs_.segment<3>(modes_ * g) += t;
      if (modes_ == 6) coarse_rhs_.segment<3>(6 * g + 3) += aggregate_offset_[i].cross(t);
    }
    coarse_.solveInPlace(coarse_rhs_);
    for (Index i = 0; i < na; ++i) {
      const Index g = aggregate_of_[i];
      Vec3 move = coarse_rhs_.segment<3>(modes_ * g);
      if (modes_ == 6) move -= aggregate_offset_[i].cross(coarse_rhs_.segment<3>(6 * g + 3));
      z.segment<3>(3 * i) += free_component_[i].cwiseProduct(move);
    }
    a.multiply(z, sweep_);
    sweep_ = r - sweep_;
    backward_sweep(a, sweep_, q_two_);
    z += q_two_;
    return;
  }
  // Symmetric block Gauss-Seidel, z = M^-1 r with M = (D+L) D^-1 (D+U) (the paper's §3.3):
  // forward sweep (D+L) y = r, then backward sweep (D+U) z = D y.
  forward_sweep(a, r, z);
  const std::vector<Index>& ptr = a.block_ptr();
  for (Index i = na - 1; i >= 0; --i) {
    const Index d = a.diagonal_block(i);
    const Vec3 s = row_product(a, z, i, d + 1, ptr[i + 1]);
    z.segment<3>(3 * i) -= diagonal_inverse_[i] * s;
  }
}

LinearSolveReport LinearSolver::solve_pcg(const BlockSparseMatrix& a, const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  LinearSolveReport report;
  if (!invert_diagonal_blocks(a, report.message)) {
    x.setZero(a.size());
    report.indefinite = true;
    return report;
  }
  if (options_.kind == LinearSolverKind::pcg_two_level) prepare_two_level(a);
  const double b_norm = b.norm();
  if (!options_.warm_start || x.size() != a.size() || !all_finite(x)) x.setZero(a.size());
  // r = b - A x
  if (x.squaredNorm() == 0.0) {
    r_ = b;
  } else {
    a.multiply(x, q_);
    r_ = b - q_;
  }
  const double target = options_.relative_tolerance * b_norm;
  const CgEnd end =
      conjugate_gradients(a, x, target, options_.max_iterations,
                          [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { apply_preconditioner(a, r, z); });
  if (end.breakdown) {
    report.message = "matrix or preconditioner is not positive definite (CG breakdown)";
    report.indefinite = end.indefinite;
  }
  const double r_norm = end.residual_norm;
  report.iterations = end.iterations;
  // The recurrence residual drifts from the true one; report the true one.
  a.multiply(x, q_);
  report.relative_residual = (b - q_).norm() / b_norm;
  report.converged = report.message.empty() && r_norm <= target;
  if (!report.converged && report.message.empty())
    report.message = "PCG reached " + std::to_string(options_.max_iterations) + " iterations at relative residual " +
                     std::to_string(report.relative_residual);
  return report;
}

}  // namespace shatter
