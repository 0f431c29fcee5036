// libFuzzer entry point for the static case reader (JSON): any bytes must give a case or an Error,
// never a crash, a stack overflow or an unbounded allocation.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/scene/static_case.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)shatter::parse_static_case(std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.json");
  return 0;
}
