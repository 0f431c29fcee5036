// VTK XML UnstructuredGrid (.vtu) writer and reader.
// Written layout: version 1.0, LittleEndian, header_type UInt64; every array inline, either ascii
// or base64 of (UInt64 byte count + data) as one stream, or (compress) zlib-compressed in blocks
// (vtkZLibDataCompressor: the block header and the blocks as two base64 runs, as VTK writes).
// Points Float64 x3; Cells connectivity and offsets Int64, types UInt8 (10); PointData node_id
// (Int64), node_tag (Int32); CellData tet_id (Int64), tag (Int32); then the requested fields as
// Float64.
// Read: ascii, inline base64 and <AppendedData> (raw or base64 encoding, arrays found by their
// offset), each uncompressed or zlib-compressed; UInt32 or UInt64 headers, either byte order; one
// Piece; non-tet cells are counted in `skipped`.
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <ostream>
#include <set>
#include <type_traits>

#include "shatter/mesh/io/base64.h"
#include "shatter/mesh/io/mesh_io.h"
#include "shatter/mesh/io/mesh_io_util.h"
#include "shatter/mesh/io/scalar_type.h"
#include "shatter/mesh/io/text_cursor.h"
#include "shatter/mesh/io/vtk_zlib.h"
#include "shatter/mesh/io/xml_lite.h"

namespace shatter {
namespace {

using io::ScalarArray;
using io::ScalarType;
using io::XmlDocument;
using io::XmlElement;

class VtuReader {
 public:
  VtuReader(std::string_view bytes, const std::string& name) : bytes_(bytes), name_(name) {}

  Result<MeshReadResult> read() {
    std::size_t p = bytes_.size() >= 3 && bytes_.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0;
    while (p < bytes_.size() && (bytes_[p] == ' ' || bytes_[p] == '\n' || bytes_[p] == '\r' || bytes_[p] == '\t')) ++p;
    if (p >= bytes_.size()) return line_error(name_, 1, "empty file: expected a VTK XML file");
    // Appended data is raw bytes after a '_', not XML: parse the XML up to the end of the
    // <AppendedData> start tag, closed by hand, and read the arrays from the bytes after the '_'.
    // The text before is the file's own, so lines and offsets stay those of the file.
    std::string xml_text;
    std::string_view xml = bytes_;
    if (const std::size_t at = bytes_.find("<AppendedData"); at != std::string_view::npos) {
      const std::size_t gt = bytes_.find('>', at);
      if (gt == std::string_view::npos)
        return line_error(name_, io::line_of(bytes_, at), "file ends inside the <AppendedData> tag");
      std::size_t q = gt + 1;
      while (q < bytes_.size() && (bytes_[q] == ' ' || bytes_[q] == '\n' || bytes_[q] == '\r' || bytes_[q] == '\t'))
        ++q;
      if (bytes_[gt - 1] == '/' || q >= bytes_.size() || bytes_[q] != '_')
        return line_error(name_, io::line_of(bytes_, at), "expected '_' to start the data of <AppendedData>");
      const std::size_t end = bytes_.rfind("</AppendedData>");
      if (end == std::string_view::npos || end <= q)
        return line_error(name_, io::line_of(bytes_, at),
                          "no </AppendedData> after the appended data (file truncated?)");
      // Only </VTKFile> may follow (anything else: a truncated or spliced file).
      std::size_t tail = end + std::string_view("</AppendedData>").size();
      auto skip_blank = [&] {
        while (tail < bytes_.size() &&
               (bytes_[tail] == ' ' || bytes_[tail] == '\n' || bytes_[tail] == '\r' || bytes_[tail] == '\t'))
          ++tail;
      };
      skip_blank();
      const bool closed = bytes_.substr(tail, 10) == "</VTKFile>";
      tail += 10;
      skip_blank();
      if (!closed || tail < bytes_.size())
        return line_error(name_, io::line_of(bytes_, end),
                          "expected </VTKFile> and the end of the file after </AppendedData> (file truncated?)");
      appended_ = bytes_.substr(q + 1, end - q - 1);
      appended_begin_ = q + 1;
      xml_text.assign(bytes_.substr(0, gt + 1));
      xml_text += "</AppendedData></VTKFile>";
      xml = xml_text;
      has_appended_ = true;
    }
    SHATTER_TRY(parsed, io::parse_xml(xml, name_));
    doc_ = std::move(*parsed);
    const XmlElement& root = doc_.elements[0];
    if (root.name != "VTKFile")
      return err(root, "expected the root element <VTKFile>, found <" + std::string(root.name) + ">");
    const std::string* type = root.attribute("type");
    if (!type || *type != "UnstructuredGrid")
      return err(root,
                 "expected VTKFile type=\"UnstructuredGrid\", found " + io::quote_token(type ? *type : std::string()));
    if (const std::string* c = root.attribute("compressor"); c && !c->empty()) {
      if (*c != "vtkZLibDataCompressor")
        return err(root, "compressor " + io::quote_token(*c) + " is not supported (only vtkZLibDataCompressor)");
      compressed_ = true;
    }
    if (const std::string* bo = root.attribute("byte_order")) {
      if (*bo == "BigEndian")
        big_endian_ = true;
      else if (*bo != "LittleEndian")
        return err(root, "unknown byte_order " + io::quote_token(*bo));
    }
    if (const std::string* ht = root.attribute("header_type")) {
      if (*ht == "UInt64")
        header_size_ = 8;
      else if (*ht != "UInt32")
        return err(root, "unknown header_type " + io::quote_token(*ht));
    }
    const std::vector<int> grids = doc_.children(0, "UnstructuredGrid");
    if (grids.size() != 1) return err(root, "expected one <UnstructuredGrid> element");
    const std::vector<int> pieces = doc_.children(grids[0], "Piece");
    if (pieces.empty())
      return err(doc_.elements[static_cast<std::size_t>(grids[0])], "no <Piece> in <UnstructuredGrid>");
    if (pieces.size() > 1)
      return err(doc_.elements[static_cast<std::size_t>(pieces[1])], "only one <Piece> is supported");
    if (has_appended_) {
      const std::vector<int> app = doc_.children(0, "AppendedData");
      if (app.size() != 1) return err(root, "<AppendedData> must be a child of <VTKFile>");
      const XmlElement& a = doc_.elements[static_cast<std::size_t>(app[0])];
      const std::string* enc = a.attribute("encoding");
      if (!enc || (*enc != "raw" && *enc != "base64"))
        return err(a, "expected <AppendedData encoding=\"raw\"> or \"base64\", found " +
                          io::quote_token(enc ? *enc : std::string()));
      appended_base64_ = *enc == "base64";
      // Where each appended array ends (base64 runs have no length of their own): the next offset.
      for (const XmlElement& e : doc_.elements)
        if (const std::string* f = e.attribute("format"); e.name == "DataArray" && f && *f == "appended") {
          SHATTER_TRY(o, appended_offset(e));
          offsets_.insert(*o);
        }
    }
    return read_piece(pieces[0]);
  }

 private:
  Error err(const XmlElement& e, const std::string& msg) const {
    return line_error(name_, io::line_of(bytes_, e.offset), msg);
  }

  /// "DataArray "Points" (line 12)" for messages about one array's data.
  std::string label(const XmlElement& e) const {
    const std::string* n = e.attribute("Name");
    return "DataArray " + io::quote_token(n ? *n : std::string()) + " (line " +
           std::to_string(io::line_of(bytes_, e.offset)) + ")";
  }

  /// The `offset` attribute of an appended DataArray, inside the appended data.
  Result<std::uint64_t> appended_offset(const XmlElement& e) const {
    const std::string* s = e.attribute("offset");
    std::int64_t v = 0;
    if (!s || !io::parse_int(*s, v)) return err(e, "appended DataArray needs an integer attribute offset");
    if (v < 0 || static_cast<std::uint64_t>(v) >= appended_.size())
      return err(e, "offset " + std::to_string(v) + " is outside the " + std::to_string(appended_.size()) +
                        " bytes of appended data");
    return static_cast<std::uint64_t>(v);
  }

  Result<std::int64_t> count_attribute(const XmlElement& e, const char* attr) {
    const std::string* s = e.attribute(attr);
    std::int64_t v = 0;
    if (!s || !io::parse_int(*s, v)) return err(e, std::string("expected an integer attribute ") + attr);
    if (v < 0 || v > std::numeric_limits<Index>::max())
      return err(e, std::string(attr) + " " + std::to_string(v) + " out of range");
    return v;
  }

  std::vector<int> first_child(int parent, std::string_view n) {
    std::vector<int> all = doc_.children(parent, n);
    if (all.size() > 1) all.resize(1);
    return all;
  }

  /// The DataArray children of `parent`.
  std::vector<int> arrays(int parent) { return doc_.children(parent, "DataArray"); }

  /// Decode a DataArray of `count` values (tuples x components).
  Result<ScalarArray> read_array(const XmlElement& e, std::int64_t tuples, int expected_components) {
    const std::string* tname = e.attribute("type");
    const auto type = tname ? io::scalar_type_from_name(io::ScalarNames::vtu, *tname) : std::nullopt;
    if (!type)
      return err(e, "DataArray has an unknown or missing type " + io::quote_token(tname ? *tname : std::string()));
    const ScalarType t = *type;
    std::int64_t comps = 1;
    if (const std::string* nc = e.attribute("NumberOfComponents"))
      if (!io::parse_int(*nc, comps) || comps < 1 || comps > 1024)
        return err(e, "bad NumberOfComponents " + io::quote_token(*nc));
    if (expected_components > 0 && comps != expected_components)
      return err(e, "expected NumberOfComponents=\"" + std::to_string(expected_components) + "\", found " +
                        std::to_string(comps));
    const std::uint64_t count = static_cast<std::uint64_t>(tuples) * static_cast<std::uint64_t>(comps);
    const std::string* fmt = e.attribute("format");
    const std::string format = fmt ? *fmt : "ascii";
    // The data is the text before any child element (VTK puts <InformationKey> elements after it).
    std::string_view content = bytes_.substr(e.content_begin, e.content_end - e.content_begin);
    content = content.substr(0, content.find('<'));
    ScalarArray v;
    v.integral = !io::is_float(t);
    if (format == "ascii") {
      if (count > content.size() / 2 + 1)
        return err(e, "DataArray holds fewer values than the " + std::to_string(count) + " expected");
      // Lines inside the content count from the DataArray's line.
      io::TextCursor c(content, name_);
      auto fail = [&](Error error) {
        error.line += io::line_of(bytes_, e.content_begin) - 1;
        return error;
      };
      v.reserve(count);
      for (std::uint64_t i = 0; i < count; ++i) {
        if (v.integral) {
          auto x = c.next_int("integer array value");
          if (!x) return fail(x.error());
          v.ints.push_back(*x);
        } else {
          auto x = c.next_double("array value");
          if (!x) return fail(x.error());
          v.reals.push_back(*x);
        }
      }
      if (!c.next_token().empty())
        return fail(c.error("DataArray holds more than the " + std::to_string(count) + " values expected"));
      return v;
    }
    if (format != "binary" && format != "appended")
      return err(e, "unknown DataArray format " + io::quote_token(format));
    const std::size_t size = io::scalar_size(t);
    if (count > std::numeric_limits<std::uint64_t>::max() / size)
      return err(e, label(e) + ": " + std::to_string(count) + " values are too many");
    const std::uint64_t expected_bytes = count * size;
    // The array's bytes, from its header on: decoded base64 (inline, or appended base64) or the
    // file's own bytes (appended raw).
    std::string decoded;
    std::string_view data;
    std::size_t start = 0;
    std::string where = name_;
    if (format == "appended") {
      if (!has_appended_) return err(e, label(e) + " is format=\"appended\" but the file has no <AppendedData>");
      SHATTER_TRY(offset, appended_offset(e));
      if (appended_base64_) {
        // This array's base64 text runs to the next array's offset.
        const auto next = offsets_.upper_bound(*offset);
        const std::uint64_t end = next == offsets_.end() ? appended_.size() : *next;
        const std::string_view text = appended_.substr(*offset, end - *offset);
        std::size_t bad = 0;
        if (!io::base64_decode(text, decoded, bad))
          return offset_error(name_, static_cast<std::int64_t>(appended_begin_ + *offset + bad),
                              label(e) + ": invalid base64 in the appended data");
        data = decoded;
        where = name_ + " (decoded appended " + label(e) + ")";
      } else {
        // Raw: offsets in errors are those of the file.
        data = bytes_.substr(0, appended_begin_ + appended_.size());
        start = appended_begin_ + *offset;
      }
    } else {
      std::size_t bad = 0;
      if (!io::base64_decode(content, decoded, bad))
        return line_error(name_, io::line_of(bytes_, e.content_begin + bad), "invalid base64 in " + label(e));
      data = decoded;
      where = name_ + " (decoded " + label(e) + ")";
    }
    io::ByteCursor b(data, where, start, big_endian_);
    std::string expanded;
    if (compressed_) {
      SHATTER_TRY(x, io::vtk_zlib_decompress(b, header_size_, expected_bytes, label(e)));
      expanded = std::move(*x);
      b = io::ByteCursor(expanded, name_ + " (uncompressed " + label(e) + ")", 0, big_endian_);
    } else {
      std::uint64_t nbytes = 0;
      if (header_size_ == 8) {
        SHATTER_TRY(h, b.u64("array byte count"));
        nbytes = *h;
      } else {
        SHATTER_TRY(h, b.u32("array byte count"));
        nbytes = *h;
      }
      if (auto r = b.require(count, size, "array values"); !r) return r.error();
      if (nbytes != expected_bytes)
        return err(e, "DataArray header says " + std::to_string(nbytes) + " bytes, expected " +
                          std::to_string(expected_bytes));
    }
    v.reserve(count);
    SHATTER_TRY(ok, io::read_scalars(b, t, count, "value", v));
    return v;
  }

  Result<std::vector<std::int64_t>> integer_array(const XmlElement& e, std::int64_t tuples) {
    SHATTER_TRY(v, read_array(e, tuples, 1));
    if (v->integral) return std::move(v->ints);
    std::vector<std::int64_t> r;
    r.reserve(v->reals.size());
    for (double x : v->reals) {
      if (!(std::fabs(x) <= 9.0e15) || x != std::floor(x))
        return err(e, "expected integers, found " + std::to_string(x));
      r.push_back(static_cast<std::int64_t>(x));
    }
    return r;
  }

  const XmlElement* named_array(int parent, std::string_view n) {
    for (int i : arrays(parent)) {
      const XmlElement& e = doc_.elements[static_cast<std::size_t>(i)];
      if (const std::string* s = e.attribute("Name"); s && *s == n) return &e;
    }
    return nullptr;
  }

  Result<MeshReadResult> read_piece(int piece) {
    const XmlElement& pe = doc_.elements[static_cast<std::size_t>(piece)];
    SHATTER_TRY(np, count_attribute(pe, "NumberOfPoints"));
    SHATTER_TRY(nc, count_attribute(pe, "NumberOfCells"));
    const std::vector<int> points = doc_.children(piece, "Points");
    const std::vector<int> cells = doc_.children(piece, "Cells");
    if (points.size() != 1) return err(pe, "expected one <Points> in <Piece>");
    if (cells.size() != 1) return err(pe, "expected one <Cells> in <Piece>");
    const std::vector<int> parr = arrays(points[0]);
    if (parr.empty()) return err(doc_.elements[static_cast<std::size_t>(points[0])], "<Points> has no DataArray");
    const XmlElement& pa = doc_.elements[static_cast<std::size_t>(parr[0])];
    SHATTER_TRY(pv, read_array(pa, *np, 3));
    MeshReadResult out;
    // "vtu ascii", "vtu binary", "vtu binary zlib", "vtu appended raw zlib", ...: as the points are stored.
    const std::string* pfmt = pa.attribute("format");
    const std::string pf = pfmt ? *pfmt : "ascii";
    out.format = "vtu " + (pf == "appended" ? std::string(appended_base64_ ? "appended base64" : "appended raw") : pf) +
                 (compressed_ && pf != "ascii" ? " zlib" : "");
    TetMesh& m = out.mesh;
    m.positions.resize(static_cast<std::size_t>(*np));
    for (std::int64_t i = 0; i < *np; ++i)
      for (int k = 0; k < 3; ++k) {
        const std::size_t j = static_cast<std::size_t>(3 * i + k);
        const double x = pv->integral ? static_cast<double>(pv->ints[j]) : pv->reals[j];
        if (!std::isfinite(x)) return err(pa, "point " + std::to_string(i) + " has a coordinate that is not finite");
        m.positions[static_cast<std::size_t>(i)][k] = x;
      }
    const XmlElement* conn_e = named_array(cells[0], "connectivity");
    const XmlElement* off_e = named_array(cells[0], "offsets");
    const XmlElement* types_e = named_array(cells[0], "types");
    const XmlElement& ce = doc_.elements[static_cast<std::size_t>(cells[0])];
    if (!conn_e || !off_e || !types_e) return err(ce, "<Cells> needs DataArrays named connectivity, offsets and types");
    SHATTER_TRY(offsets, integer_array(*off_e, *nc));
    SHATTER_TRY(types, integer_array(*types_e, *nc));
    // The connectivity length is the last offset; check it against the offsets first.
    std::int64_t prev = 0;
    for (std::int64_t o : *offsets) {
      if (o < prev) return err(*off_e, "cell offsets decrease");
      prev = o;
    }
    SHATTER_TRY(conn, integer_array(*conn_e, prev));
    std::map<std::int64_t, std::int64_t> skipped;
    std::vector<std::size_t> tet_cells;
    for (std::int64_t i = 0; i < *nc; ++i) {
      const std::int64_t b = i == 0 ? 0 : (*offsets)[static_cast<std::size_t>(i - 1)];
      const std::int64_t e = (*offsets)[static_cast<std::size_t>(i)];
      if ((*types)[static_cast<std::size_t>(i)] != 10) {
        ++skipped[(*types)[static_cast<std::size_t>(i)]];
        continue;
      }
      if (e - b != 4)
        return err(*off_e, "cell " + std::to_string(i) + " is a tetrahedron (type 10) with " + std::to_string(e - b) +
                               " points");
      TetIndices t;
      for (int k = 0; k < 4; ++k) {
        const std::int64_t v = (*conn)[static_cast<std::size_t>(b + k)];
        if (v < 0 || v >= *np)
          return err(*conn_e, "cell " + std::to_string(i) + " references point " + std::to_string(v) +
                                  ", but there are " + std::to_string(*np) + " points");
        t[k] = static_cast<Index>(v);
      }
      m.tets.push_back(t);
      tet_cells.push_back(static_cast<std::size_t>(i));
    }
    if (m.tets.empty()) return err(ce, "no tetrahedra (cell type 10) in the file");
    // Ids and tags.
    // One PointData and one CellData per Piece (later ones are ignored).
    for (int pd : first_child(piece, "PointData")) {
      if (const XmlElement* a = named_array(pd, "node_id")) {
        SHATTER_TRY(v, integer_array(*a, *np));
        m.node_ids = std::move(*v);
      }
      if (const XmlElement* a = named_array(pd, "node_tag")) {
        SHATTER_TRY(v, tags_array(*a, *np));
        m.node_tags = std::move(*v);
      }
    }
    for (int cd : first_child(piece, "CellData")) {
      if (const XmlElement* a = named_array(cd, "tet_id")) {
        SHATTER_TRY(v, integer_array(*a, *nc));
        for (std::size_t i : tet_cells) m.tet_ids.push_back((*v)[i]);
      }
      for (const char* tag_name : {"tag", "tet_tag", "gmsh:physical", "medit:ref"}) {
        if (const XmlElement* a = named_array(cd, tag_name)) {
          SHATTER_TRY(v, tags_array(*a, *nc));
          m.tet_tags.clear();
          for (std::size_t i : tet_cells) m.tet_tags.push_back((*v)[i]);
          break;
        }
      }
    }
    for (const auto& [type, n] : skipped)
      out.skipped.push_back(io::count_phrase(n, "cell", "cells") + " of vtk type " + std::to_string(type));
    if (!skipped.empty()) {
      const Index dropped = io::drop_unused_nodes(m);
      if (dropped > 0) out.skipped.push_back(io::count_phrase(dropped, "node", "nodes") + " used by no tetrahedron");
    }
    io::drop_default_ids(m.node_ids);
    io::drop_default_ids(m.tet_ids);
    return out;
  }

  Result<std::vector<std::int32_t>> tags_array(const XmlElement& e, std::int64_t tuples) {
    SHATTER_TRY(v, integer_array(e, tuples));
    std::vector<std::int32_t> r;
    r.reserve(v->size());
    for (std::int64_t x : *v) {
      if (x < std::numeric_limits<std::int32_t>::min() || x > std::numeric_limits<std::int32_t>::max())
        return err(e, "tag " + std::to_string(x) + " does not fit 32 bits");
      r.push_back(static_cast<std::int32_t>(x));
    }
    return r;
  }

  std::string_view bytes_;
  std::string name_;
  XmlDocument doc_;
  bool big_endian_ = false;
  int header_size_ = 4;
  bool compressed_ = false;          ///< compressor="vtkZLibDataCompressor"
  bool has_appended_ = false;        ///< the file has <AppendedData>
  bool appended_base64_ = false;     ///< its encoding is base64 (else raw)
  std::string_view appended_;        ///< the bytes after its '_', up to </AppendedData>
  std::size_t appended_begin_ = 0;   ///< where appended_ starts in the file
  std::set<std::uint64_t> offsets_;  ///< the offsets of every appended DataArray
};

/// Writes DataArrays in the chosen layout.
class ArrayWriter {
 public:
  ArrayWriter(io::WriteBuffer& w, bool binary, bool compress)
      : w_(w), binary_(binary || compress), compress_(compress) {}

  template <class T, class Get>
  void write(std::string_view indent, const char* type, std::string_view name, int components, std::size_t count,
             Get&& get) {
    w_ << indent << "<DataArray type=\"" << type << "\" Name=\"" << io::xml_escape(name) << '"';
    if (components != 1) {
      w_ << " NumberOfComponents=\"";
      w_.integer(components);
      w_ << '"';
    }
    w_ << " format=\"" << (binary_ ? "binary" : "ascii") << "\">\n" << indent << "  ";
    if (binary_) {
      std::string raw;
      const std::uint64_t nbytes = count * sizeof(T);
      const std::size_t at = compress_ ? 0 : 8;  // uncompressed: the byte count leads the data
      raw.resize(at + nbytes);
      if (!compress_) std::memcpy(raw.data(), &nbytes, 8);
      for (std::size_t i = 0; i < count; ++i) {
        const T v = get(i);
        std::memcpy(raw.data() + at + i * sizeof(T), &v, sizeof(T));
      }
      std::string text;
      if (compress_) {
        // VTK's layout: the block header and the blocks as two separate base64 runs.
        std::string header, blocks;
        io::vtk_zlib_compress(raw, kCompressBlockSize, header, blocks);
        io::base64_encode(header, text);
        io::base64_encode(blocks, text);
      } else {
        io::base64_encode(raw, text);
      }
      w_ << text;
    } else {
      for (std::size_t i = 0; i < count; ++i) {
        if (i > 0) w_ << ((i % 12 == 0) ? '\n' : ' ');
        if (i > 0 && i % 12 == 0) w_ << indent << "  ";
        if constexpr (std::is_floating_point_v<T>)
          w_.number(get(i));
        else
          w_.integer(static_cast<std::int64_t>(get(i)));
      }
    }
    w_ << '\n' << indent << "</DataArray>\n";
  }

 private:
  /// Uncompressed bytes per zlib block (VTK's default).
  static constexpr std::size_t kCompressBlockSize = 32768;
  io::WriteBuffer& w_;
  bool binary_;
  bool compress_;
};

}  // namespace

Result<MeshReadResult> parse_vtu(std::string_view bytes, const std::string& name) {
  VtuReader reader(bytes, name);
  return reader.read();
}

Result<void> write_vtu(std::ostream& out, const TetMesh& mesh, const MeshWriteOptions& options) {
  static_assert(std::endian::native == std::endian::little, "the VTU writer assumes a little-endian machine");
  const Index nn = mesh.num_nodes(), ne = mesh.num_tets();
  if (auto ok = io::check_mesh_for_writing("write_vtu", mesh, options); !ok) return ok;

  io::WriteBuffer w(out);
  ArrayWriter a(w, options.binary, options.compress);
  const std::string_view in = "        ";
  w << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
       "header_type=\"UInt64\"";
  if (options.compress) w << " compressor=\"vtkZLibDataCompressor\"";
  w << ">\n";
  w << "  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"";
  w.integer(nn);
  w << "\" NumberOfCells=\"";
  w.integer(ne);
  w << "\">\n";
  w << "      <PointData>\n";
  if (!mesh.node_ids.empty())
    a.write<std::int64_t>(in, "Int64", "node_id", 1, mesh.node_ids.size(),
                          [&](std::size_t i) { return mesh.node_ids[i]; });
  if (!mesh.node_tags.empty())
    a.write<std::int32_t>(in, "Int32", "node_tag", 1, mesh.node_tags.size(),
                          [&](std::size_t i) { return mesh.node_tags[i]; });
  for (const MeshField& f : options.fields.node_fields)
    a.write<double>(in, "Float64", f.name, f.components, f.values.size(), [&](std::size_t i) { return f.values[i]; });
  w << "      </PointData>\n      <CellData>\n";
  if (!mesh.tet_ids.empty())
    a.write<std::int64_t>(in, "Int64", "tet_id", 1, mesh.tet_ids.size(),
                          [&](std::size_t i) { return mesh.tet_ids[i]; });
  if (!mesh.tet_tags.empty())
    a.write<std::int32_t>(in, "Int32", "tag", 1, mesh.tet_tags.size(), [&](std::size_t i) { return mesh.tet_tags[i]; });
  for (const MeshField& f : options.fields.tet_fields)
    a.write<double>(in, "Float64", f.name, f.components, f.values.size(), [&](std::size_t i) { return f.values[i]; });
  w << "      </CellData>\n      <Points>\n";
  a.write<double>(in, "Float64", "Points", 3, static_cast<std::size_t>(nn) * 3,
                  [&](std::size_t i) { return mesh.positions[i / 3][static_cast<Index>(i % 3)]; });
  w << "      </Points>\n      <Cells>\n";
  const std::size_t ne4 = static_cast<std::size_t>(ne) * 4;
  a.write<std::int64_t>(in, "Int64", "connectivity", 1, ne4,
                        [&](std::size_t i) { return std::int64_t{mesh.tets[i / 4][i % 4]}; });
  a.write<std::int64_t>(in, "Int64", "offsets", 1, static_cast<std::size_t>(ne),
                        [&](std::size_t i) { return static_cast<std::int64_t>(4 * (i + 1)); });
  a.write<std::uint8_t>(in, "UInt8", "types", 1, static_cast<std::size_t>(ne),
                        [](std::size_t) { return std::uint8_t{10}; });
  w << "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
  w.flush();
  if (!w.good()) return make_error("write_vtu: the output stream failed");
  return {};
}

}  // namespace shatter
