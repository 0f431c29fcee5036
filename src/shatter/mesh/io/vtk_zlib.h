// The block layout of VTK XML's vtkZLibDataCompressor, through zlib.
//
// A compressed array is a header of integers (UInt32 or UInt64, the file's header_type, in its
// byte order): [number of blocks n, uncompressed block size, uncompressed size of the last block
// (0: a full block), compressed size of block 0, ..., of block n-1], followed by the n blocks,
// each an independent zlib stream. Every block but the last holds `block size` bytes when
// uncompressed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "shatter/core/error.h"
#include "shatter/mesh/io/text_cursor.h"

namespace shatter::io {

/// The most bytes one zlib stream can expand to per compressed byte (deflate's limit is about
/// 1032:1); a block that claims more cannot be genuine and is refused before anything is allocated.
inline constexpr std::uint64_t kZlibMaxRatio = 1032;

/// Read a compressed array at the cursor (its header, then its blocks) and return the
/// uncompressed bytes. `header_size` is 4 or 8; `expected_bytes` is what the array must hold
/// (values x value size): the header must say exactly that. Every size in the header is checked
/// against the bytes that remain and against kZlibMaxRatio before any allocation; `what` names the
/// array in messages ("DataArray \"Points\" (line 12)").
Result<std::string> vtk_zlib_decompress(ByteCursor& b, int header_size, std::uint64_t expected_bytes,
                                        const std::string& what);

/// Compress `data` in blocks of `block_size` bytes; `header` receives the UInt64 little-endian
/// header and `blocks` the compressed blocks (VTK writes them as two base64 runs).
void vtk_zlib_compress(std::string_view data, std::size_t block_size, std::string& header, std::string& blocks);

}  // namespace shatter::io
