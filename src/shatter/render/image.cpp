#include "shatter/render/image.h"

#include <zlib.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

#include "shatter/core/file_io.h"

namespace shatter::render {
namespace {

void put_u32(std::string& out, std::uint32_t v) {
  out.push_back(static_cast<char>((v >> 24) & 0xff));
  out.push_back(static_cast<char>((v >> 16) & 0xff));
  out.push_back(static_cast<char>((v >> 8) & 0xff));
  out.push_back(static_cast<char>(v & 0xff));
}

std::uint32_t get_u32(const std::string& s, std::size_t at) {
  return (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at])) << 24) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 1])) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 2])) << 8) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(s[at + 3]));
}

void put_chunk(std::string& out, const char* type, const std::string& data) {
  put_u32(out, static_cast<std::uint32_t>(data.size()));
  const std::string body = std::string(type, 4) + data;
  out += body;
  put_u32(out, static_cast<std::uint32_t>(
                   crc32(0L, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
}

constexpr std::array<unsigned char, 8> kSignature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

int paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return a;
  return pb <= pc ? b : c;
}

}  // namespace

std::string encode_png(const Image& image, bool alpha) {
  const int channels = alpha ? 4 : 3;
  const auto w = static_cast<std::size_t>(image.width);
  const auto h = static_cast<std::size_t>(image.height);
  // Each row: filter byte, then the row filtered with "up" (a good, cheap choice for renders).
  std::string raw;
  raw.reserve(h * (1 + w * static_cast<std::size_t>(channels)));
  for (std::size_t y = 0; y < h; ++y) {
    raw.push_back(static_cast<char>(y == 0 ? 0 : 2));
    for (std::size_t x = 0; x < w; ++x) {
      const std::uint8_t* p = image.rgba.data() + (y * w + x) * 4;
      const std::uint8_t* up = y == 0 ? nullptr : p - w * 4;
      for (int c = 0; c < channels; ++c)
        raw.push_back(static_cast<char>(up ? static_cast<std::uint8_t>(p[c] - up[c]) : p[c]));
    }
  }
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::string z(size, '\0');
  compress2(reinterpret_cast<Bytef*>(z.data()), &size, reinterpret_cast<const Bytef*>(raw.data()),
            static_cast<uLong>(raw.size()), 6);
  z.resize(size);

  std::string out(kSignature.begin(), kSignature.end());
  std::string ihdr;
  put_u32(ihdr, static_cast<std::uint32_t>(image.width));
  put_u32(ihdr, static_cast<std::uint32_t>(image.height));
  ihdr += {8, static_cast<char>(alpha ? 6 : 2), 0, 0, 0};  // depth 8, colour type, deflate, filters, no interlace
  put_chunk(out, "IHDR", ihdr);
  put_chunk(out, "IDAT", z);
  put_chunk(out, "IEND", "");
  return out;
}

Result<void> write_png(const std::string& path, const Image& image, bool alpha) {
  if (image.width <= 0 || image.height <= 0) return make_error(path + ": an empty image");
  return write_file_atomic(path, encode_png(image, alpha));
}

Result<Image> decode_png(const std::string& bytes, const std::string& name) {
  auto bad = [&](const std::string& what) { return make_error(name + ": " + what); };
  if (bytes.size() < 8 || !std::equal(kSignature.begin(), kSignature.end(), bytes.begin(),
                                      [](unsigned char a, char b) { return a == static_cast<unsigned char>(b); }))
    return bad("not a PNG file");
  std::size_t at = 8;
  int width = 0, height = 0, channels = 0;
  std::string z;
  bool ended = false;
  while (at + 12 <= bytes.size() && !ended) {
    const std::uint32_t len = get_u32(bytes, at);
    if (len > bytes.size() - at - 12) return bad("truncated chunk");
    const std::string type = bytes.substr(at + 4, 4);
    const std::size_t data = at + 8;
    if (type == "IHDR") {
      if (len != 13) return bad("bad IHDR");
      const std::uint32_t w = get_u32(bytes, data), hh = get_u32(bytes, data + 4);
      const int depth = static_cast<unsigned char>(bytes[data + 8]);
      const int ctype = static_cast<unsigned char>(bytes[data + 9]);
      const int interlace = static_cast<unsigned char>(bytes[data + 12]);
      if (depth != 8) return bad("only 8-bit PNGs are read (bit depth " + std::to_string(depth) + ")");
      if (interlace != 0) return bad("interlaced PNGs are not read");
      switch (ctype) {
        case 0: channels = 1; break;
        case 4: channels = 2; break;
        case 2: channels = 3; break;
        case 6: channels = 4; break;
        default: return bad("PNG colour type " + std::to_string(ctype) + " is not read (grey, RGB or RGBA)");
      }
      if (w == 0 || hh == 0 || w > 16384 || hh > 16384) return bad("image size out of range (1..16384)");
      width = static_cast<int>(w);
      height = static_cast<int>(hh);
    } else if (type == "IDAT") {
      z.append(bytes, data, len);
    } else if (type == "IEND") {
      ended = true;
    }
    at += 12 + len;
  }
  if (channels == 0) return bad("no IHDR chunk");
  const std::size_t stride = static_cast<std::size_t>(width) * static_cast<std::size_t>(channels);
  std::string raw(static_cast<std::size_t>(height) * (stride + 1), '\0');
  uLongf raw_size = static_cast<uLongf>(raw.size());
  if (uncompress(reinterpret_cast<Bytef*>(raw.data()), &raw_size, reinterpret_cast<const Bytef*>(z.data()),
                 static_cast<uLong>(z.size())) != Z_OK ||
      raw_size != raw.size())
    return bad("corrupt image data");
  Image img(width, height);
  std::vector<std::uint8_t> prev(stride, 0), cur(stride);
  for (int y = 0; y < height; ++y) {
    const std::size_t row = static_cast<std::size_t>(y) * (stride + 1);
    const int filter = static_cast<unsigned char>(raw[row]);
    for (std::size_t i = 0; i < stride; ++i) {
      const int x = static_cast<unsigned char>(raw[row + 1 + i]);
      const int a = i >= static_cast<std::size_t>(channels) ? cur[i - static_cast<std::size_t>(channels)] : 0;
      const int b = prev[i];
      const int c = i >= static_cast<std::size_t>(channels) ? prev[i - static_cast<std::size_t>(channels)] : 0;
      int v = 0;
      switch (filter) {
        case 0: v = x; break;
        case 1: v = x + a; break;
        case 2: v = x + b; break;
        case 3: v = x + (a + b) / 2; break;
        case 4: v = x + paeth(a, b, c); break;
        default: return bad("bad row filter " + std::to_string(filter));
      }
      cur[i] = static_cast<std::uint8_t>(v & 0xff);
    }
    for (int xx = 0; xx < width; ++xx) {
      std::uint8_t* p = img.pixel(xx, y);
      const std::uint8_t* s = cur.data() + static_cast<std::size_t>(xx) * static_cast<std::size_t>(channels);
      if (channels <= 2) {
        p[0] = p[1] = p[2] = s[0];
        p[3] = channels == 2 ? s[1] : 255;
      } else {
        p[0] = s[0];
        p[1] = s[1];
        p[2] = s[2];
        p[3] = channels == 4 ? s[3] : 255;
      }
    }
    std::swap(prev, cur);
  }
  return img;
}

Result<Image> read_png(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(path + ": cannot open");
  std::ostringstream ss;
  ss << in.rdbuf();
  return decode_png(ss.str(), path);
}

ImageDifference compare_images(const Image& a, const Image& b, int tol) {
  ImageDifference d;
  if (a.width != b.width || a.height != b.height || a.rgba.size() != b.rgba.size()) {
    d.mean_abs = std::numeric_limits<double>::infinity();
    d.fraction_over = 1;
    return d;
  }
  double sum = 0;
  std::size_t over = 0;
  const std::size_t n = a.rgba.size() / 4;
  for (std::size_t i = 0; i < n; ++i) {
    int worst = 0;
    for (int c = 0; c < 3; ++c) {
      const int diff = std::abs(static_cast<int>(a.rgba[i * 4 + c]) - static_cast<int>(b.rgba[i * 4 + c]));
      sum += diff;
      worst = std::max(worst, diff);
    }
    if (worst > tol) ++over;
  }
  d.mean_abs = n ? sum / (3.0 * static_cast<double>(n)) : 0;
  d.fraction_over = n ? static_cast<double>(over) / static_cast<double>(n) : 0;
  return d;
}

}  // namespace shatter::render
