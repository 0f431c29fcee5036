// Determinism hashes (xxHash64) of arrays and whole states: same scene and build => same hash
// on any thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>

namespace shatter {

/// Streaming 64-bit hash. Feed values in a fixed order; digest() may be called at any time.
class Hasher {
 public:
  explicit Hasher(std::uint64_t seed = 0);
  ~Hasher();
  Hasher(const Hasher&) = delete;
  Hasher& operator=(const Hasher&) = delete;

  void add_bytes(const void* data, std::size_t size);
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void add(const T& value) { add_bytes(&value, sizeof(T)); }
  template <class T>
    requires std::is_trivially_copyable_v<T>
  void add(std::span<const T> values) { add_bytes(values.data(), values.size_bytes()); }
  void add(std::string_view s) { add_bytes(s.data(), s.size()); }

  [[nodiscard]] std::uint64_t digest() const;

 private:
  void* state_;
};

std::uint64_t hash_bytes(const void* data, std::size_t size, std::uint64_t seed = 0);
/// 16 lowercase hex digits.
std::string hash_to_hex(std::uint64_t hash);

}  // namespace shatter
