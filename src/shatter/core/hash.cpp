#include "shatter/core/hash.h"

#include <xxhash.h>

#include <cstdio>

namespace shatter {

Hasher::Hasher(std::uint64_t seed) : state_(XXH64_createState()) {
  XXH64_reset(static_cast<XXH64_state_t*>(state_), seed);
}
Hasher::~Hasher() { XXH64_freeState(static_cast<XXH64_state_t*>(state_)); }
void Hasher::add_bytes(const void* data, std::size_t size) {
  if (size > 0) XXH64_update(static_cast<XXH64_state_t*>(state_), data, size);
}
std::uint64_t Hasher::digest() const { return XXH64_digest(static_cast<XXH64_state_t*>(state_)); }

std::uint64_t hash_bytes(const void* data, std::size_t size, std::uint64_t seed) { return XXH64(data, size, seed); }

std::string hash_to_hex(std::uint64_t hash) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(hash));
  return buf;
}

}  // namespace shatter
