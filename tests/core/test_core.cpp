#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

#include "shatter/core/error.h"
#include "shatter/core/file_io.h"
#include "shatter/core/hash.h"
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

TEST(Parallel, ThreadCountIsClamped) {
  set_num_threads(2'000'000'000);
  EXPECT_EQ(num_threads(), kMaxThreads);
  set_num_threads(-5);
  EXPECT_EQ(num_threads(), 1);
}

}  // namespace
}  // namespace shatter
