// Threading. Results never depend on the thread count: parallel loops write only to their own
// indices, and reductions go through fixed-size chunks summed in chunk order.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#ifdef SHATTER_HAS_OPENMP
#include <omp.h>
#endif

namespace shatter {

/// Most threads set_num_threads accepts: the OpenMP runtime sizes per-thread state for the count it
/// is given (2^31 threads asked 481 GB of it), so larger counts are clamped here and refused by the CLI.
inline constexpr int kMaxThreads = 1024;
/// Threads used by shatter's parallel loops (default: hardware threads). 1 = serial; n < 1 counts
/// as 1, n > kMaxThreads as kMaxThreads.
void set_num_threads(int n);
/// Threads the parallel loops use now (always 1 in a build without OpenMP).
int num_threads();

/// for i in [begin, end): body(i). Iterations must be independent. Runs in parallel only when
/// end - begin >= min_parallel: a parallel region costs microseconds on idle cores but up to a
/// scheduler time slice when the cores are oversubscribed (every barrier waits for the slowest,
/// possibly descheduled, thread), so only loops with a few hundred microseconds of work should
/// choose a threshold that lets them go parallel.
template <class Body>
void parallel_for(std::int64_t begin, std::int64_t end, Body&& body, std::int64_t min_parallel = 2048) {
#ifdef SHATTER_HAS_OPENMP
  const int threads = num_threads();
  if (threads > 1 && end - begin >= min_parallel) {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (std::int64_t i = begin; i < end; ++i) body(i);
    return;
  }
#else
  (void)min_parallel;
#endif
  for (std::int64_t i = begin; i < end; ++i) body(i);
}

/// Deterministic sum of body(i) over [begin, end): partial sums over fixed chunks of `chunk`
/// indices (independent of the thread count), then added in chunk order. Parallel from two chunks
/// on, or from min_parallel indices when that is more (the bits do not depend on it).
template <class T, class Body>
T parallel_sum(std::int64_t begin, std::int64_t end, T zero, Body&& body, std::int64_t chunk = 4096,
               std::int64_t min_parallel = 0) {
  const std::int64_t n = end - begin;
  if (n <= 0) return zero;
  const std::int64_t chunks = (n + chunk - 1) / chunk;
  std::vector<T> partial(static_cast<std::size_t>(chunks), zero);
  parallel_for(
      0, chunks,
      [&](std::int64_t c) {
        T s = zero;
        const std::int64_t lo = begin + c * chunk;
        const std::int64_t hi = std::min(end, lo + chunk);
        for (std::int64_t i = lo; i < hi; ++i) s += body(i);
        partial[static_cast<std::size_t>(c)] = s;
      },
      std::max<std::int64_t>(2, (min_parallel + chunk - 1) / chunk));
  T total = zero;
  for (const T& p : partial) total += p;
  return total;
}

}  // namespace shatter
