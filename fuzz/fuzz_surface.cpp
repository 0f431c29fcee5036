// libFuzzer target for the surface readers: the first byte picks OBJ, PLY or STL.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/mesh/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  switch (data[0] % 3) {
    case 0: (void)shatter::parse_obj(bytes, "fuzz.obj"); break;
    case 1: (void)shatter::parse_ply(bytes, "fuzz.ply"); break;
    default: (void)shatter::parse_stl(bytes, "fuzz.stl"); break;
  }
  return 0;
}
