// Buffered writing and node compaction for the MSH / VTK / VTU code.
#include "shatter/mesh/io/mesh_io_util.h"

#include <ostream>

#include "shatter/mesh/io/scalar_type.h"

namespace shatter::io {

template <class T>
void WriteBuffer::raw(T v, bool big_endian) {
  append_binary(buf_, v, big_endian);
  maybe_flush();
}
template void WriteBuffer::raw<double>(double, bool);
template void WriteBuffer::raw<float>(float, bool);
template void WriteBuffer::raw<std::int32_t>(std::int32_t, bool);
template void WriteBuffer::raw<std::int64_t>(std::int64_t, bool);
template void WriteBuffer::raw<std::uint64_t>(std::uint64_t, bool);
template void WriteBuffer::raw<std::uint8_t>(std::uint8_t, bool);

void WriteBuffer::flush() {
  if (!buf_.empty()) out_.write(buf_.data(), static_cast<std::streamsize>(buf_.size()));
  buf_.clear();
}

bool WriteBuffer::good() const { return static_cast<bool>(out_); }

Index drop_unused_nodes(TetMesh& mesh) {
  std::vector<bool> drop(static_cast<std::size_t>(mesh.num_nodes()), true);
  for (const TetIndices& t : mesh.tets)
    for (Index v : t) drop[static_cast<std::size_t>(v)] = false;
  Index n = 0;
  for (bool d : drop) n += d ? 1 : 0;
  if (n > 0) remove_nodes(mesh, drop);
  return n;
}

std::string count_phrase(std::int64_t n, std::string_view singular, std::string_view plural) {
  return std::to_string(n) + " " + std::string(n == 1 ? singular : plural);
}

}  // namespace shatter::io
