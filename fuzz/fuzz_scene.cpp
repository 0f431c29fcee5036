// libFuzzer entry point for the scene reader (JSON): any bytes must give a scene or an Error, never
// a crash, a stack overflow or an unbounded allocation. Parsing only: building a scene reads the
// mesh files it names and meshes its shapes, which the mesh and shape fuzzers cover.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/scene/scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)shatter::parse_scene(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.json", "/nonexistent");
  return 0;
}
