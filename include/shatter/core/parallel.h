// Threading. Results never depend on the thread count: parallel loops write only to their own
// indices, and reductions go through fixed-size chunks summed in chunk order.
//
// The loops run on shatter's own pool of worker threads (docs/architecture.md, "Threads"). The
// calling thread always takes part and claims chunks of the range one at a time, as do the
// workers that are awake (each starting in its own share of the chunks, the caller in the first,
// then helping with the others'); it waits only for chunks a worker has already claimed, never for
// a worker to arrive. When other programs hold the cores, a descheduled worker therefore costs at
// most the chunk it is in, and a worker that never wakes costs nothing: the caller does its share.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace shatter {

/// Most threads set_num_threads accepts (larger counts are clamped here and refused by the CLI).
inline constexpr int kMaxThreads = 1024;
/// Threads used by shatter's parallel loops, the calling thread included. Default: the
/// environment's SHATTER_NUM_THREADS, else OMP_NUM_THREADS, else the hardware threads. 1 = serial;
/// n < 1 counts as 1, n > kMaxThreads as kMaxThreads.
void set_num_threads(int n);
/// Threads the parallel loops use now (always 1 in a build with SHATTER_THREADS off).
int num_threads();

namespace detail {
/// Runs call(context, c) for every chunk c in [0, chunks) on up to `threads` threads (the caller
/// and pool workers), each chunk exactly once; returns when all have run. Serial when threads < 2
/// or when called from inside a parallel loop.
void run_chunks(std::int64_t chunks, void (*call)(void*, std::int64_t), void* context, int threads);
/// True on a pool worker, and on any thread while it runs the chunks of a parallel loop.
bool in_parallel_region();
}  // namespace detail

/// for i in [begin, end): body(i). Iterations must be independent. An exception thrown by body
/// reaches the caller once every chunk has stopped (the first one thrown; the rest of the chunks
/// still run). Runs in parallel only when
/// end - begin >= min_parallel: waking workers and handing out chunks costs a few microseconds, so
/// only loops with a few hundred microseconds of work should choose a threshold that lets them go
/// parallel.
template <class Body>
void parallel_for(std::int64_t begin, std::int64_t end, Body&& body, std::int64_t min_parallel = 2048) {
  const std::int64_t n = end - begin;
  if (n <= 0) return;
  const int threads = num_threads();
  if (threads > 1 && n >= min_parallel && !detail::in_parallel_region()) {
    // About 8 chunks per thread: small enough that the caller can take over a late worker's
    // share, large enough that claiming them costs nothing measurable.
    const std::int64_t chunks = std::min<std::int64_t>(n, 8 * static_cast<std::int64_t>(threads));
    struct Context {
      Body* body;
      std::int64_t begin, n, chunks;
    } context{&body, begin, n, chunks};
    detail::run_chunks(
        chunks,
        [](void* p, std::int64_t c) {
          const Context& ctx = *static_cast<const Context*>(p);
          const std::int64_t lo = ctx.begin + c * ctx.n / ctx.chunks;
          const std::int64_t hi = ctx.begin + (c + 1) * ctx.n / ctx.chunks;
          for (std::int64_t i = lo; i < hi; ++i) (*ctx.body)(i);
        },
        &context, threads);
    return;
  }
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
