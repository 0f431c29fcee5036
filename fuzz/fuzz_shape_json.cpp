// libFuzzer entry point for the shape-file reader (JSON -> signed distance tree): any bytes must
// give a shape or an Error, never a crash, a stack overflow or an unbounded allocation.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/meshing/shape_json.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)shatter::parse_shape_json(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.json");
  return 0;
}
