// vtkZLibDataCompressor blocks: a bounded reader and a writer, through zlib.
#include "shatter/mesh/io/vtk_zlib.h"

#include <zlib.h>

#include <limits>
#include <vector>

#include "shatter/mesh/io/scalar_type.h"

namespace shatter::io {
namespace {

Result<std::uint64_t> header_value(ByteCursor& b, int header_size, const char* what) {
  if (header_size == 8) return b.u64(what);
  SHATTER_TRY(v, b.u32(what));
  return std::uint64_t{*v};
}

}  // namespace

Result<std::string> vtk_zlib_decompress(ByteCursor& b, int header_size, std::uint64_t expected_bytes,
                                        const std::string& what) {
  const std::size_t header_at = b.position();
  SHATTER_TRY(nblocks, header_value(b, header_size, "compression header (number of blocks)"));
  SHATTER_TRY(block_size, header_value(b, header_size, "compression header (block size)"));
  SHATTER_TRY(last_size, header_value(b, header_size, "compression header (last block size)"));
  // The header alone needs nblocks more values: bound the count by the bytes present first.
  if (auto r = b.require(*nblocks, static_cast<std::uint64_t>(header_size), "compression header (block sizes)"); !r)
    return b.error(what + ": " + r.error().message);
  std::uint64_t total = 0;
  if (*nblocks > 0) {
    if (*block_size == 0) return b.error(what + ": compression header gives a block size of 0");
    if (*last_size > *block_size)
      return b.error(what + ": compression header gives a last block of " + std::to_string(*last_size) +
                     " bytes, larger than the block size " + std::to_string(*block_size));
    const std::uint64_t last = *last_size == 0 ? *block_size : *last_size;
    if (*nblocks - 1 > (std::numeric_limits<std::uint64_t>::max() - last) / *block_size)
      return b.error(what + ": compression header sizes overflow (" + std::to_string(*nblocks) + " blocks of " +
                     std::to_string(*block_size) + " bytes)");
    total = (*nblocks - 1) * *block_size + last;
  }
  if (total != expected_bytes)
    return offset_error(b.error("").file, static_cast<std::int64_t>(header_at),
                        what + ": compression header says " + std::to_string(total) + " bytes uncompressed, expected " +
                            std::to_string(expected_bytes));
  std::vector<std::uint64_t> compressed(static_cast<std::size_t>(*nblocks));
  std::uint64_t compressed_total = 0;
  for (std::uint64_t k = 0; k < *nblocks; ++k) {
    SHATTER_TRY(c, header_value(b, header_size, "compression header (compressed block size)"));
    // compressed_total never exceeds the bytes remaining, so the sum cannot wrap.
    if (*c > b.remaining() - compressed_total)
      return b.error(what + ": compressed block " + std::to_string(k) + " of " + std::to_string(*c) +
                     " bytes does not fit in the " + std::to_string(b.remaining()) + " bytes that remain");
    compressed[k] = *c;
    compressed_total += *c;
  }
  std::string out;
  for (std::uint64_t k = 0; k < *nblocks; ++k) {
    const std::uint64_t size = k + 1 < *nblocks || *last_size == 0 ? *block_size : *last_size;
    if (size > compressed[k] * kZlibMaxRatio + 64)
      return b.error(what + ": block " + std::to_string(k) + " claims " + std::to_string(size) + " bytes from " +
                     std::to_string(compressed[k]) + " compressed bytes, more than zlib can produce");
    const std::size_t block_at = b.position();
    SHATTER_TRY(src, b.take(static_cast<std::size_t>(compressed[k]), "a compressed block"));
    // Grows only by what this block may really produce (bounded just above).
    const std::size_t at = out.size();
    out.resize(at + static_cast<std::size_t>(size));
    uLongf produced = static_cast<uLongf>(size);
    uLong consumed = static_cast<uLong>(src->size());
    const int rc = uncompress2(reinterpret_cast<Bytef*>(out.data() + at), &produced,
                               reinterpret_cast<const Bytef*>(src->data()), &consumed);
    if (rc != Z_OK || produced != size) {
      const std::string why =
          rc == Z_OK ? "holds " + std::to_string(produced) + " bytes, its header gives " + std::to_string(size)
          : rc == Z_BUF_ERROR
              ? "is truncated or holds more than the " + std::to_string(size) + " bytes its header gives"
          : rc == Z_MEM_ERROR ? std::string("cannot be expanded: out of memory")
                              : std::string("is not a valid zlib stream");
      std::string message = what;
      message += ": compressed block " + std::to_string(k) + " " + why;
      return offset_error(b.error("").file, static_cast<std::int64_t>(block_at), message);
    }
  }
  return out;
}

void vtk_zlib_compress(std::string_view data, std::size_t block_size, std::string& header, std::string& blocks) {
  const std::size_t nblocks = (data.size() + block_size - 1) / block_size;
  const std::uint64_t last = data.size() % block_size;  // VTK writes 0 for a full last block
  std::vector<std::uint64_t> h = {nblocks, block_size, last};
  std::string buf;
  for (std::size_t k = 0; k < nblocks; ++k) {
    const std::string_view block = data.substr(k * block_size, block_size);
    uLongf n = compressBound(static_cast<uLong>(block.size()));
    buf.resize(static_cast<std::size_t>(n));
    [[maybe_unused]] const int rc =
        compress2(reinterpret_cast<Bytef*>(buf.data()), &n, reinterpret_cast<const Bytef*>(block.data()),
                  static_cast<uLong>(block.size()), Z_DEFAULT_COMPRESSION);
    SHATTER_ASSERT(rc == Z_OK);  // only fails for a short buffer (compressBound) or no memory
    blocks.append(buf.data(), static_cast<std::size_t>(n));
    h.push_back(n);
  }
  for (std::uint64_t v : h) append_binary(header, v, false);
}

}  // namespace shatter::io
