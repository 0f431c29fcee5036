// libFuzzer entry point for the VTK reader: any bytes must give a mesh or an Error, never a crash.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/mesh/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)shatter::parse_vtk(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.vtk");
  return 0;
}
