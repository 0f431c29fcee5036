// libFuzzer entry point for the VTU reader: any bytes must give a mesh or an Error, never a crash.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/mesh/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)shatter::parse_vtu(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.vtu");
  return 0;
}
