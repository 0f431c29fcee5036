#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "shatter/core/error.h"
#include "shatter/core/file_io.h"
#include "shatter/core/hash.h"
#include "shatter/core/log.h"
#include "shatter/core/memory.h"
#include "shatter/core/parallel.h"
#include "shatter/core/random.h"
#include "support/test_support.h"

namespace shatter {
namespace {

TEST(Error, FormatsLocation) {
  EXPECT_EQ(line_error("a.msh", 12, "expected x").to_string(), "a.msh:12: expected x");
  EXPECT_EQ(offset_error("a.msh", 40, "bad marker").to_string(), "a.msh: byte 40: bad marker");
  EXPECT_EQ(field_error("loads[2].force", "expected 3 numbers").to_string(), "loads[2].force: expected 3 numbers");
}

TEST(Result, CarriesValueOrError) {
  Result<int> a = 3;
  ASSERT_TRUE(a.ok());
  EXPECT_EQ(*a, 3);
  Result<int> b = make_error("no");
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().message, "no");
}

// The library's messages all go to the sink the application sets, from any thread, each whole and
// with its level; setting a sink hands back the one it replaces.
TEST(Log, SinkTakesEveryMessageFromAnyThread) {
  std::vector<std::pair<LogLevel, std::string>> got;  // the sink is called one message at a time
  LogSink previous = set_log_sink([&](LogLevel level, std::string_view message) { got.emplace_back(level, message); });
  ASSERT_TRUE(previous);  // the tests' guard
  log_warning("first");
  log_info("second");
  log_message(LogLevel::error, "third");
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([t] {
      for (int i = 0; i < 100; ++i) log_message(LogLevel::debug, "thread " + std::to_string(t));
    });
  for (std::thread& t : threads) t.join();
  LogSink ours = set_log_sink(std::move(previous));
  EXPECT_TRUE(ours);
  ASSERT_EQ(got.size(), 403u);
  EXPECT_EQ(got[0], std::make_pair(LogLevel::warning, std::string("first")));
  EXPECT_EQ(got[1], std::make_pair(LogLevel::info, std::string("second")));
  EXPECT_EQ(got[2], std::make_pair(LogLevel::error, std::string("third")));
  std::array<int, 4> per_thread{};
  for (std::size_t k = 3; k < got.size(); ++k) {
    EXPECT_EQ(got[k].first, LogLevel::debug);
    ASSERT_EQ(got[k].second.rfind("thread ", 0), 0u);
    ++per_thread[static_cast<std::size_t>(got[k].second.back() - '0')];
  }
  for (const int n : per_thread) EXPECT_EQ(n, 100);
  log_info("after");  // to the restored sink, not ours
  EXPECT_EQ(got.size(), 403u);
}

TEST(Random, MapsBitsDeterministically) {
  Random r(42);
  Random s(42);
  for (int i = 0; i < 100; ++i) {
    const double u = r.uniform();
    EXPECT_GE(u, 0.0);
    EXPECT_LT(u, 1.0);
    EXPECT_EQ(u, s.uniform());
  }
  // Golden values pin the bit-to-number mapping across platforms and builds.
  Random g(1);
  EXPECT_EQ(g.next_u64(), 0x910a2dec89025cc1ULL);
}

TEST(Hash, StableAndSensitive) {
  const double v[3] = {1.0, 2.0, 3.0};
  Hasher h;
  h.add(std::span<const double>(v, 3));
  EXPECT_EQ(h.digest(), hash_bytes(v, sizeof v));
  // A span over mutable data hashes its elements too, not the span object.
  std::vector<double> copy(v, v + 3);
  Hasher g;
  g.add(std::span(copy));
  EXPECT_EQ(g.digest(), h.digest());
  const double w[3] = {1.0, 2.0, 3.0000000000000004};
  EXPECT_NE(hash_bytes(v, sizeof v), hash_bytes(w, sizeof w));
}

// Sanitizers replace the allocator (their mallopt does nothing): the settings are glibc's.
TEST(Memory, FreedBlocksStayInTheProcess) {
#if defined(SHATTER_TEST_SANITIZED)
  GTEST_SKIP() << "a sanitizer's allocator replaces glibc's";
#elif defined(__GLIBC__)
  ASSERT_TRUE(keep_freed_memory());
  // An 8 MiB block, by default mmapped and unmapped when freed, now comes from the heap and stays
  // there as free memory.
  constexpr std::size_t kBlock = std::size_t{8} << 20;
  const std::size_t mapped_before = mallinfo2().hblkhd;
  auto* block = static_cast<volatile char*>(std::malloc(kBlock));
  ASSERT_NE(block, nullptr);
  block[0] = 1;
  block[kBlock - 1] = 1;
  EXPECT_EQ(mallinfo2().hblkhd, mapped_before);
  std::free(const_cast<char*>(block));
  EXPECT_GE(mallinfo2().fordblks, kBlock);
#else
  EXPECT_FALSE(keep_freed_memory());
#endif
}

TEST(Parallel, SumIndependentOfThreadCount) {
  auto f = [](std::int64_t i) { return 1.0 / static_cast<double>(i + 1); };
  set_num_threads(1);
  const double s1 = parallel_sum(0, 100000, 0.0, f);
  set_num_threads(2);
  const double s2 = parallel_sum(0, 100000, 0.0, f);
  set_num_threads(5);
  const double s5 = parallel_sum(0, 100000, 0.0, f);
  EXPECT_EQ(s1, s2);
  EXPECT_EQ(s1, s5);
}

TEST(Parallel, EveryIndexExactlyOnceOnAnyThreadCount) {
  const int saved = num_threads();
  for (int threads : {1, 2, 3, 8, 33}) {
    set_num_threads(threads);
    for (std::int64_t n : {1, 2, 7, 100, 263, 10007}) {
      std::vector<int> hits(static_cast<std::size_t>(n), 0);
      parallel_for(0, n, [&](std::int64_t i) { ++hits[static_cast<std::size_t>(i)]; }, 1);
      EXPECT_EQ(std::count(hits.begin(), hits.end(), 1), n) << threads << " threads, " << n;
    }
    // An offset range, and an empty one.
    std::vector<int> hits(50, 0);
    parallel_for(10, 40, [&](std::int64_t i) { ++hits[static_cast<std::size_t>(i)]; }, 1);
    EXPECT_EQ(std::count(hits.begin(), hits.end(), 1), 30);
    parallel_for(5, 5, [&](std::int64_t) { ADD_FAILURE(); }, 1);
  }
  set_num_threads(saved);
}

TEST(Parallel, NestedLoopsAndConcurrentCallersFinish) {
  // A loop inside a loop runs serially on its thread; two threads of the program may start loops
  // at the same time. Both must cover every index once and return.
  const int saved = num_threads();
  set_num_threads(4);
  std::vector<std::int64_t> sums(64, 0);
  parallel_for(
      0, 64,
      [&](std::int64_t i) {
        EXPECT_TRUE(detail::in_parallel_region());
        std::vector<std::int64_t> inner(100, 0);
        parallel_for(0, 100, [&](std::int64_t j) { inner[static_cast<std::size_t>(j)] = j; }, 1);
        sums[static_cast<std::size_t>(i)] = std::accumulate(inner.begin(), inner.end(), std::int64_t{0});
      },
      1);
  for (std::int64_t s : sums) EXPECT_EQ(s, 4950);
  EXPECT_FALSE(detail::in_parallel_region());
  std::vector<double> a(20000, 0.0), b(20000, 0.0);
  auto fill = [](std::vector<double>& v, double k) {
    for (int round = 0; round < 50; ++round)
      parallel_for(
          0, static_cast<std::int64_t>(v.size()), [&](std::int64_t i) { v[static_cast<std::size_t>(i)] += k; }, 1);
  };
  std::thread other([&] { fill(b, 2.0); });
  fill(a, 1.0);
  other.join();
  EXPECT_EQ(std::count(a.begin(), a.end(), 50.0), 20000);
  EXPECT_EQ(std::count(b.begin(), b.end(), 100.0), 20000);
  set_num_threads(saved);
}

TEST(Parallel, AnExceptionReachesTheCallerAfterEveryChunkStopped) {
  // A loop body that throws: the caller gets the exception only once no chunk runs any more (they
  // use its stack), and the pool stays usable.
  const int saved = num_threads();
  set_num_threads(4);
  std::vector<std::atomic<int>> hits(4000);
  EXPECT_THROW(parallel_for(
                   0, 4000,
                   [&](std::int64_t i) {
                     if (i == 1234) throw std::runtime_error("chunk failed");
                     hits[static_cast<std::size_t>(i)].fetch_add(1);
                   },
                   1),
               std::runtime_error);
  for (const std::atomic<int>& h : hits) EXPECT_LE(h.load(), 1);
  std::vector<int> again(4000, 0);
  parallel_for(0, 4000, [&](std::int64_t i) { again[static_cast<std::size_t>(i)] = 1; }, 1);
  EXPECT_EQ(std::count(again.begin(), again.end(), 1), 4000);
  EXPECT_FALSE(detail::in_parallel_region());
  set_num_threads(1);
  EXPECT_THROW(parallel_for(0, 10, [](std::int64_t) { throw std::runtime_error("serial"); }, 1), std::runtime_error);
  EXPECT_FALSE(detail::in_parallel_region());
  set_num_threads(saved);
}

TEST(FileIo, AtomicWriteLeavesOldFileOnFailure) {
  test::TempDir dir;
  const std::string path = dir.file("out.txt");
  ASSERT_OK(write_file_atomic(path, "first"));
  const Result<void> r = write_file_atomic(path, [](std::ostream& out) -> Result<void> {
    out << "half";
    return make_error("simulated failure");
  });
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.error().file, path);
  auto content = read_file(path);
  ASSERT_OK(content);
  EXPECT_EQ(*content, "first");
  // No temporary left behind.
  int files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1);
}

TEST(FileIo, ReadErrorsNameTheFile) {
  auto r = read_file("/nonexistent/x.msh");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().to_string().find("/nonexistent/x.msh"), std::string::npos);
}

TEST(FileIo, ReadRefusesWhatIsNotARegularFile) {
  test::TempDir dir;
  ASSERT_EQ(test::run_command("mkfifo '" + dir.file("pipe") + "'").status, 0);
  auto r = read_file(dir.file("pipe"));  // would block forever if opened
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("a named pipe"), std::string::npos) << r.error().to_string();
  r = read_file("/dev/zero");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("a character device"), std::string::npos) << r.error().to_string();
  r = read_file(dir.path().string());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("directory"), std::string::npos) << r.error().to_string();
}

// A file made by `truncate -s 10G` is refused at once from its holes, not read as 10 GiB of zeros;
// one larger than the limit is refused from its size. Neither takes time or memory.
TEST(FileIo, ReadRefusesSparseAndOversizedFiles) {
  test::TempDir dir;
  const std::string path = dir.file("huge.msh");
  { std::ofstream(path) << "$MeshFormat\n"; }
  std::filesystem::resize_file(path, 10ULL << 30);
  auto r = read_file(path);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("is a sparse file"), std::string::npos) << r.error().to_string();
  EXPECT_EQ(r.error().file, path);
  r = read_file(path, 1ULL << 20);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("larger than the limit of 1048576"), std::string::npos) << r.error().to_string();
  // A file with a hole shorter than the check's threshold is read as it is.
  std::filesystem::resize_file(path, 4096);
  r = read_file(path);
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  EXPECT_EQ(r->size(), 4096U);
  EXPECT_EQ(r->substr(0, 12), "$MeshFormat\n");
}

TEST(FileIo, AtomicWriteOfAVeryLongName) {
  test::TempDir dir;
  const std::string path = dir.file(std::string(250, 'a') + ".csv");  // 254 bytes: the temporary must be shorter
  ASSERT_OK(write_file_atomic(path, "x"));
  auto content = read_file(path);
  ASSERT_OK(content);
  EXPECT_EQ(*content, "x");
}

std::string text_of(const std::string& path) {
  auto r = read_file(path);
  return r.ok() ? *r : "<" + r.error().message + ">";
}

int entries(const test::TempDir& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++n;
  return n;
}

TEST(OutputBatch, AllOrNothing) {
  test::TempDir dir;
  const std::string a = dir.file("a.txt"), b = dir.file("b.txt"), c = dir.file("c.txt");
  ASSERT_OK(write_file_atomic(a, "a1"));
  ASSERT_OK(write_file_atomic(b, "b1"));
  ASSERT_OK(write_file_atomic(c, "stale"));
  {
    // The second output fails: the first is not replaced either, nothing is left behind.
    OutputBatch batch;
    ASSERT_OK(write_file_atomic(a, "a2"));
    EXPECT_EQ(text_of(a), "a1");  // staged, not yet in place
    EXPECT_FALSE(write_file_atomic(b, [](std::ostream&) -> Result<void> { return make_error("disk full"); }).ok());
    batch.remove_on_commit(c);
  }
  EXPECT_EQ(text_of(a), "a1");
  EXPECT_EQ(text_of(b), "b1");
  EXPECT_EQ(text_of(c), "stale");
  EXPECT_EQ(entries(dir), 3);
  {
    // All written: all replaced at commit; a nested batch joins the outer one; a stale file goes.
    OutputBatch batch;
    ASSERT_OK(write_file_atomic(a, "a2"));
    {
      OutputBatch inner;
      ASSERT_OK(write_file_atomic(b, "b2"));
      ASSERT_OK(inner.commit());
    }
    EXPECT_EQ(text_of(b), "b1");            // the inner commit leaves the renames to the outer batch
    ASSERT_OK(write_file_atomic(a, "a3"));  // the same target again: the later content wins
    batch.remove_on_commit(c);
    ASSERT_OK(batch.commit());
  }
  EXPECT_EQ(text_of(a), "a3");
  EXPECT_EQ(text_of(b), "b2");
  EXPECT_FALSE(std::filesystem::exists(c));
  EXPECT_EQ(entries(dir), 2);
  // Outside a batch, writes land at once again.
  ASSERT_OK(write_file_atomic(a, "a4"));
  EXPECT_EQ(text_of(a), "a4");
}

TEST(Parallel, ThreadCountIsClamped) {
  set_num_threads(2'000'000'000);
  EXPECT_EQ(num_threads(), kMaxThreads);
  set_num_threads(-5);
  EXPECT_EQ(num_threads(), 1);
}

}  // namespace
}  // namespace shatter
