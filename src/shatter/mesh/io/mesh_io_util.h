// Helpers shared by the MSH, VTK and VTU readers and writers: a buffered byte sink for writers
// and dropping nodes that no tetrahedron uses.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <string_view>

#include "shatter/core/error.h"
#include "shatter/mesh/io/io_util.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/tet_mesh.h"

namespace shatter::io {

/// Collects output in memory and hands it to the stream in large blocks.
class WriteBuffer {
 public:
  explicit WriteBuffer(std::ostream& out) : out_(out) {}
  ~WriteBuffer() { flush(); }
  WriteBuffer(const WriteBuffer&) = delete;
  WriteBuffer& operator=(const WriteBuffer&) = delete;
  std::string& text() { return buf_; }
  WriteBuffer& operator<<(std::string_view s) {
    buf_ += s;
    maybe_flush();
    return *this;
  }
  WriteBuffer& operator<<(char c) {
    buf_ += c;
    return *this;
  }
  void number(double v) {
    append_double(buf_, v);
    maybe_flush();
  }
  void integer(std::int64_t v) {
    append_int(buf_, v);
    maybe_flush();
  }
  /// Raw bytes of a trivially copyable value, little- or big-endian.
  template <class T>
  void raw(T v, bool big_endian);
  void maybe_flush() {
    if (buf_.size() >= (1u << 20)) flush();
  }
  void flush();
  /// False if the stream failed.
  [[nodiscard]] bool good() const;

 private:
  std::ostream& out_;
  std::string buf_;
};

/// Remove nodes used by no tet (positions, node_ids, node_tags follow; node_sets are remapped
/// and lose the dropped nodes). Returns the number removed.
Index drop_unused_nodes(TetMesh& mesh);

/// "12 triangles" / "1 triangle".
std::string count_phrase(std::int64_t n, std::string_view singular, std::string_view plural);

/// Checks a mesh and its fields before a writer that stores attributes and fields (VTK, VTU):
/// attribute arrays of the right length, fields of (#nodes or #tets) x components values, tet node
/// indices in range. Messages start with `writer` ("write_vtk").
Result<void> check_mesh_for_writing(std::string_view writer, const TetMesh& mesh, const MeshWriteOptions& options);

}  // namespace shatter::io
