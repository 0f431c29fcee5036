// libFuzzer target for the MEDIT .mesh reader.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/mesh/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)shatter::parse_medit(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.mesh");
  return 0;
}
