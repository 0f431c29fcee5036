// libFuzzer entry point for the MSH reader: any bytes must give a mesh or an Error, never a crash.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/mesh/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)shatter::parse_msh(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.msh");
  return 0;
}
