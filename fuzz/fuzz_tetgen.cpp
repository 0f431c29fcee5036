// libFuzzer target for the TetGen reader: the input is split at the first NUL byte into the
// .node and .ele texts.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "shatter/mesh/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view all(reinterpret_cast<const char*>(data), size);
  const std::size_t cut = all.find('\0');
  const std::string_view node = all.substr(0, cut);
  const std::string_view ele = cut == std::string_view::npos ? std::string_view() : all.substr(cut + 1);
  (void)shatter::parse_tetgen(node, "fuzz.node", ele, "fuzz.ele");
  return 0;
}
