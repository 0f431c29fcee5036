// Buffered writing, node compaction and the writers' input checks for the MSH / VTK / VTU code.
#include "shatter/mesh/io/mesh_io_util.h"

#include <algorithm>
#include <ostream>
#include <string>

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

Result<void> check_mesh_for_writing(std::string_view writer, const TetMesh& mesh, const MeshWriteOptions& options) {
  const Index nn = mesh.num_nodes(), ne = mesh.num_tets();
  auto bad_size = [&](const std::string& what, std::size_t got, std::size_t want) {
    return make_error(std::string(writer) + ": " + what + " has " + std::to_string(got) + " values, expected " +
                      std::to_string(want));
  };
  if (!mesh.node_ids.empty() && mesh.node_ids.size() != static_cast<std::size_t>(nn))
    return bad_size("node_ids", mesh.node_ids.size(), nn);
  if (!mesh.node_tags.empty() && mesh.node_tags.size() != static_cast<std::size_t>(nn))
    return bad_size("node_tags", mesh.node_tags.size(), nn);
  if (!mesh.tet_ids.empty() && mesh.tet_ids.size() != static_cast<std::size_t>(ne))
    return bad_size("tet_ids", mesh.tet_ids.size(), ne);
  if (!mesh.tet_tags.empty() && mesh.tet_tags.size() != static_cast<std::size_t>(ne))
    return bad_size("tet_tags", mesh.tet_tags.size(), ne);
  for (const MeshField& f : options.fields.node_fields)
    if (f.components < 1 || f.values.size() != static_cast<std::size_t>(nn) * static_cast<std::size_t>(f.components))
      return bad_size("node field " + f.name, f.values.size(),
                      static_cast<std::size_t>(nn) * static_cast<std::size_t>(std::max(f.components, 1)));
  for (const MeshField& f : options.fields.tet_fields)
    if (f.components < 1 || f.values.size() != static_cast<std::size_t>(ne) * static_cast<std::size_t>(f.components))
      return bad_size("tet field " + f.name, f.values.size(),
                      static_cast<std::size_t>(ne) * static_cast<std::size_t>(std::max(f.components, 1)));
  for (Index e = 0; e < ne; ++e)
    for (Index v : mesh.tets[e])
      if (v < 0 || v >= nn)
        return make_error(std::string(writer) + ": tet " + std::to_string(mesh.tet_id(e)) + " has node index " +
                          std::to_string(v) + " out of range");
  return {};
}

}  // namespace shatter::io
