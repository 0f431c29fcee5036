// libFuzzer target for the Abaqus / CalculiX .inp reader.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/mesh/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)shatter::parse_inp(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.inp");
  return 0;
}
