// The contact constraints of one step laid out to be solved four at a time (Box2D v3's wide solver;
// docs/method.md §2.8). Each constraint takes the first of kColours colours in which neither of its
// responding bodies has a constraint yet (static, kinematic and sleeping bodies do not count: the
// solver never writes them), and each colour is cut into batches of four constraints that sit side
// by side in vector lanes: one instruction then works on four constraints, and the chain of
// dependent operations from one contact point to the next is shared by the four. Constraints that
// find no colour are solved one at a time after the batches.
//
// Each lane computes every formula as the one-at-a-time solver (contact_solver.h) does, in the same
// order; the solving order is colours, then batches in constraint order, then the rest. It depends
// only on the order of the constraints, so the bits are the same on any thread count and with either
// instruction set (core/simd.h).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "shatter/rigid/contact_solver.h"

namespace shatter {

struct WideContact;  // four constraints side by side (contact_batches.cpp)

class ContactBatches {
 public:
  static constexpr int kColours = 12;
  static constexpr int kLanes = 4;

  ContactBatches();
  ~ContactBatches();
  ContactBatches(const ContactBatches&);
  ContactBatches(ContactBatches&&) noexcept;
  ContactBatches& operator=(const ContactBatches&);
  ContactBatches& operator=(ContactBatches&&) noexcept;

  /// Colour and pack the prepared constraints (prepare_contact) of the step. They must stay where
  /// they are until store(). `bodies`: the solver bodies the constraints index.
  void build(std::span<ContactConstraint* const> constraints, std::span<const SolverBody> bodies);

  /// measure_approach on every constraint (at each substep's start, before warm_start).
  void measure_approach(std::span<const SolverBody> bodies);

  /// warm_start_contact on every constraint, in the solving order.
  void warm_start(std::span<SolverBody> bodies);

  /// solve_contact on every constraint, in the solving order.
  void solve(std::span<SolverBody> bodies, double inverse_h, bool use_bias, double max_push_velocity);

  /// Write the impulses, the step totals and the approach speeds back into the constraints.
  void store() const;

  /// Within a step, for a constraint the caller changes (its points found again): pull() writes
  /// its lane back into it (as store() does), and reload() packs it again once changed. Constraints
  /// solved one at a time are read in place: both leave them be. `c` must be one build() took.
  void pull(const ContactConstraint* c);
  void reload(const ContactConstraint* c, std::span<const SolverBody> bodies);
  /// A constraint made within the step (prepared), solved one at a time after all the others from
  /// the next pass on. It must stay where it is until store().
  void add(ContactConstraint* c) { overflow_.push_back(c); }

  /// The constraints of each batch (nullptr in empty lanes), in solving order.
  [[nodiscard]] std::span<const std::array<ContactConstraint*, kLanes>> batches() const { return sources_; }
  /// The colour of each batch.
  [[nodiscard]] std::span<const int> batch_colours() const { return batch_colour_; }
  /// The constraints solved one at a time, after the batches.
  [[nodiscard]] std::span<ContactConstraint* const> overflow() const { return overflow_; }

 private:
  std::vector<WideContact> wide_;
  std::vector<std::array<ContactConstraint*, kLanes>> sources_;
  std::vector<int> batch_colour_;
  std::vector<ContactConstraint*> overflow_;
  std::array<std::vector<ContactConstraint*>, kColours> colour_;
  std::vector<std::uint64_t> used_;  // per colour, one bit per body
  /// The lane of each batched constraint, by address, for pull and reload: made on the first call
  /// after build() (a lookup only; the order of the passes never depends on it).
  std::vector<std::pair<const ContactConstraint*, std::size_t>> lanes_;
  [[nodiscard]] std::size_t lane_of(const ContactConstraint* c);  // batch * kLanes + lane, or npos
};

}  // namespace shatter
