// The worker pool behind parallel_for (core/parallel.h).
#include "shatter/core/parallel.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdlib>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <system_error>
#include <thread>

namespace shatter {
namespace {

std::atomic<int> g_threads{0};  // 0 = not set: from the environment or the hardware

int threads_from_environment() {
  for (const char* name : {"SHATTER_NUM_THREADS", "OMP_NUM_THREADS"}) {
    const char* v = std::getenv(name);
    if (v == nullptr || *v == '\0') continue;
    char* end = nullptr;
    const long n = std::strtol(v, &end, 10);
    if (*end == '\0' && n >= 1) return static_cast<int>(std::min<long>(n, kMaxThreads));
  }
  return std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, kMaxThreads);
}

thread_local bool t_in_parallel = false;

#ifdef SHATTER_HAS_THREADS
// One parallel loop: its chunks are claimed through `ranges`; `done` counts the finished ones. Held
// by shared_ptr, so a worker that wakes after the loop has returned still reads valid counters (and
// finds nothing left to claim); `call` and `context` are only used for a claimed chunk, which the
// caller always waits for.
struct Job {
  // The chunks are cut into one range per thread, claimed from its start. Each thread begins with
  // its own range and then helps with the others', so from one loop to the next a thread tends to
  // get the same part of the index range (and its data stays in that core's cache), while a late
  // or descheduled thread's range is still done by the others.
  struct alignas(64) Range {
    std::atomic<std::int64_t> next{0};
    std::int64_t end = 0;
  };
  std::int64_t chunks = 0;
  void (*call)(void*, std::int64_t) = nullptr;
  void* context = nullptr;
  int helpers_wanted = 0;       // workers that may join (threads - 1)
  std::atomic<int> helpers{0};  // workers that joined
  std::unique_ptr<Range[]> ranges;
  int parts = 1;
  std::atomic<int> done{0};  // finished chunks (chunks <= 8 kMaxThreads fits an int)
  std::mutex error_mutex;
  std::exception_ptr error;  // the first exception a chunk threw (rethrown by the caller)

  Job(std::int64_t chunk_count, int threads) : chunks(chunk_count), ranges(new Range[threads]), parts(threads) {
    for (int p = 0; p < parts; ++p) {
      ranges[p].next.store(p * chunks / parts, std::memory_order_relaxed);
      ranges[p].end = (p + 1) * chunks / parts;
    }
  }

  // Participant `self`: 0 the caller, 1.. the workers in the order they joined.
  void work(int self) {
    for (int k = 0; k < parts; ++k) {
      Range& range = ranges[(self + k) % parts];
      for (;;) {
        const std::int64_t c = range.next.fetch_add(1, std::memory_order_relaxed);
        if (c >= range.end) break;
        // A chunk that throws still counts as done, so the caller never waits forever and never
        // returns (freeing what the loop body refers to) while another chunk runs.
        try {
          call(context, c);
        } catch (...) {
          const std::lock_guard<std::mutex> lock(error_mutex);
          if (!error) error = std::current_exception();
        }
        if (done.fetch_add(1, std::memory_order_acq_rel) + 1 == chunks) done.notify_all();
      }
    }
  }
};

class Pool {
 public:
  // Never destroyed (see pool()): the workers sleep until the process ends.
  void run(std::int64_t chunks, void (*call)(void*, std::int64_t), void* context, int threads) {
    auto job = std::make_shared<Job>(chunks, threads);
    job->call = call;
    job->context = context;
    job->helpers_wanted = threads - 1;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      grow(threads - 1);
      current_ = job;
      ++generation_;
    }
    wake_.notify_all();
    t_in_parallel = true;
    job->work(0);
    t_in_parallel = false;
    // Wait for the chunks that workers claimed (spin briefly: they are usually nearly done).
    for (int spin = 0; spin < 256; ++spin)
      if (job->done.load(std::memory_order_acquire) == chunks) break;
    for (int d = job->done.load(std::memory_order_acquire); d != chunks; d = job->done.load(std::memory_order_acquire))
      job->done.wait(d, std::memory_order_acquire);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (current_ == job) current_.reset();
    }
    if (job->error) std::rethrow_exception(job->error);
  }

 private:
  // Start workers up to `count` (called with mutex_ held).
  // A thread the system refuses (a process or memory limit) leaves the pool smaller: the caller
  // and the workers it has do the chunks.
  void grow(int count) {
    while (static_cast<int>(workers_.size()) < count) {
      try {
        workers_.emplace_back([this] { worker(); });
      } catch (const std::system_error&) {
        return;
      }
      workers_.back().detach();
    }
  }

  void worker() {
    t_in_parallel = true;
    std::uint64_t seen = 0;
    for (;;) {
      std::shared_ptr<Job> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return generation_ != seen; });
        seen = generation_;
        job = current_;
      }
      if (!job) continue;
      const int joined = job->helpers.fetch_add(1, std::memory_order_relaxed);
      if (joined < job->helpers_wanted) job->work(joined + 1);
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<std::thread> workers_;
  std::shared_ptr<Job> current_;
  std::uint64_t generation_ = 0;
};

Pool& pool() {
  static Pool* p = new Pool;  // intentionally never deleted: workers may still wait on it at exit
  return *p;
}
#endif

}  // namespace

void set_num_threads(int n) { g_threads.store(std::clamp(n, 1, kMaxThreads), std::memory_order_relaxed); }

int num_threads() {
#ifdef SHATTER_HAS_THREADS
  int n = g_threads.load(std::memory_order_relaxed);
  if (n > 0) return n;
  static const int from_environment = threads_from_environment();
  return from_environment;
#else
  (void)threads_from_environment;
  return 1;
#endif
}

namespace detail {

bool in_parallel_region() { return t_in_parallel; }

void run_chunks(std::int64_t chunks, void (*call)(void*, std::int64_t), void* context, int threads) {
#ifdef SHATTER_HAS_THREADS
  if (threads > 1 && chunks > 1 && !t_in_parallel) {
    pool().run(chunks, call, context, std::min(threads, kMaxThreads));
    return;
  }
#else
  (void)threads;
#endif
  struct Restore {
    bool outer = t_in_parallel;
    ~Restore() { t_in_parallel = outer; }
  } restore;
  t_in_parallel = true;
  for (std::int64_t c = 0; c < chunks; ++c) call(context, c);
}

}  // namespace detail
}  // namespace shatter
