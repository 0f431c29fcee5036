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
  template <class T>
  struct is_span : std::false_type {};
  template <class T, std::size_t N>
  struct is_span<std::span<T, N>> : std::true_type {};

 public:
  /// An empty hash started with `seed`.
  explicit Hasher(std::uint64_t seed = 0);
  /// Frees the hash state.
  ~Hasher();
  /// Not copyable (owns the xxHash state).
  Hasher(const Hasher&) = delete;
  Hasher& operator=(const Hasher&) = delete;

  /// `size` raw bytes at `data`.
  void add_bytes(const void* data, std::size_t size);
  /// The bytes of one plain value (an int, a double, an array of them).
  template <class T>
    requires(std::is_trivially_copyable_v<T> && !is_span<T>::value)
  void add(const T& value) {
    add_bytes(&value, sizeof(T));
  }
  /// The bytes of the elements a span views (not the span object itself).
  template <class T, std::size_t N>
  void add(std::span<T, N> values) {
    add_bytes(values.data(), values.size_bytes());
  }
  /// The characters of a string (not its length).
  void add(std::string_view s) { add_bytes(s.data(), s.size()); }

  /// Hash of everything added so far.
  [[nodiscard]] std::uint64_t digest() const;

 private:
  void* state_;
};

/// One-shot xxHash64 of `size` bytes at `data`.
std::uint64_t hash_bytes(const void* data, std::size_t size, std::uint64_t seed = 0);
/// 16 lowercase hex digits.
std::string hash_to_hex(std::uint64_t hash);

}  // namespace shatter
