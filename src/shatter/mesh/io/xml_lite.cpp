// Non-validating XML tokenizer (iterative, bounded depth) used by the VTU reader.
#include "shatter/mesh/io/xml_lite.h"

#include <algorithm>

#include "shatter/mesh/io/text_cursor.h"

namespace shatter::io {
namespace {

constexpr int kMaxDepth = 64;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }
bool is_name_char(char c) {
  return !is_space(c) && c != '/' && c != '>' && c != '<' && c != '=' && c != '"' && c != '\'';
}

/// Decode the five predefined entities and numeric character references (ASCII range only).
bool decode_entities(std::string_view s, std::string& out) {
  out.clear();
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '&') {
      out += s[i];
      continue;
    }
    const std::size_t semi = s.find(';', i);
    if (semi == std::string_view::npos || semi - i > 10) return false;
    const std::string_view ent = s.substr(i + 1, semi - i - 1);
    if (ent == "lt")
      out += '<';
    else if (ent == "gt")
      out += '>';
    else if (ent == "amp")
      out += '&';
    else if (ent == "quot")
      out += '"';
    else if (ent == "apos")
      out += '\'';
    else if (ent.size() >= 2 && ent[0] == '#') {
      std::int64_t v = 0;
      bool ok = false;
      if (ent[1] == 'x' || ent[1] == 'X') {
        ok = ent.size() > 2;
        for (char c : ent.substr(2)) {
          const int d = c >= '0' && c <= '9'   ? c - '0'
                        : c >= 'a' && c <= 'f' ? c - 'a' + 10
                        : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                               : -1;
          if (d < 0)
            ok = false;
          else
            v = v * 16 + d;
        }
      } else {
        ok = parse_int(ent.substr(1), v);
      }
      if (!ok || v < 1 || v > 127) return false;
      out += static_cast<char>(v);
    } else {
      return false;
    }
    i = semi;
  }
  return true;
}

}  // namespace

const std::string* XmlElement::attribute(std::string_view attr_name) const {
  for (const XmlAttribute& a : attributes)
    if (a.name == attr_name) return &a.value;
  return nullptr;
}

std::vector<int> XmlDocument::children(int parent, std::string_view name) const {
  std::vector<int> r;
  if (parent < 0 || static_cast<std::size_t>(parent) >= elements.size()) return r;
  for (int i : elements[static_cast<std::size_t>(parent)].child_indices)
    if (name.empty() || elements[static_cast<std::size_t>(i)].name == name) r.push_back(i);
  return r;
}

std::int64_t line_of(std::string_view bytes, std::size_t offset) {
  offset = std::min(offset, bytes.size());
  return 1 + std::count(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(offset), '\n');
}

std::string xml_escape(std::string_view s) {
  std::string r;
  for (char c : s) {
    switch (c) {
      case '&': r += "&amp;"; break;
      case '<': r += "&lt;"; break;
      case '>': r += "&gt;"; break;
      case '"': r += "&quot;"; break;
      case '\'': r += "&apos;"; break;
      default: r += c;
    }
  }
  return r;
}

Result<XmlDocument> parse_xml(std::string_view bytes, const std::string& name) {
  XmlDocument doc;
  std::vector<int> stack;
  std::size_t pos = 0;
  if (bytes.size() >= 3 && bytes.substr(0, 3) == "\xEF\xBB\xBF") pos = 3;
  auto err = [&](std::size_t at, const std::string& msg) { return line_error(name, line_of(bytes, at), msg); };
  bool root_closed = false;
  while (pos < bytes.size()) {
    if (bytes[pos] != '<') {
      const std::size_t next = std::min(bytes.find('<', pos), bytes.size());
      if (stack.empty())
        for (std::size_t i = pos; i < next; ++i)
          if (!is_space(bytes[i]))
            return err(i, "text outside the root element: " + quote_token(bytes.substr(i, next - i)));
      pos = next;
      continue;
    }
    const std::string_view rest = bytes.substr(pos);
    if (rest.starts_with("<?")) {
      const std::size_t end = bytes.find("?>", pos + 2);
      if (end == std::string_view::npos) return err(pos, "unterminated '<?' processing instruction");
      pos = end + 2;
      continue;
    }
    if (rest.starts_with("<!--")) {
      const std::size_t end = bytes.find("-->", pos + 4);
      if (end == std::string_view::npos) return err(pos, "unterminated comment");
      pos = end + 3;
      continue;
    }
    if (rest.starts_with("<![CDATA[")) {
      if (stack.empty()) return err(pos, "CDATA outside the root element");
      const std::size_t end = bytes.find("]]>", pos + 9);
      if (end == std::string_view::npos) return err(pos, "unterminated CDATA section");
      pos = end + 3;
      continue;
    }
    if (rest.starts_with("<!")) return err(pos, "DOCTYPE and other '<!' declarations are not supported");
    if (rest.starts_with("</")) {
      std::size_t p = pos + 2;
      const std::size_t name_begin = p;
      while (p < bytes.size() && is_name_char(bytes[p])) ++p;
      const std::string_view end_name = bytes.substr(name_begin, p - name_begin);
      while (p < bytes.size() && is_space(bytes[p])) ++p;
      if (p >= bytes.size() || bytes[p] != '>') return err(pos, "malformed end tag " + quote_token(end_name));
      if (stack.empty()) return err(pos, "end tag </" + std::string(end_name) + "> without a start tag");
      XmlElement& open = doc.elements[static_cast<std::size_t>(stack.back())];
      if (open.name != end_name)
        return err(pos, "end tag </" + std::string(end_name) + "> does not match <" + std::string(open.name) + ">");
      open.content_end = pos;
      stack.pop_back();
      if (stack.empty()) root_closed = true;
      pos = p + 1;
      continue;
    }
    // Start tag.
    if (root_closed) return err(pos, "a second root element");
    std::size_t p = pos + 1;
    const std::size_t name_begin = p;
    while (p < bytes.size() && is_name_char(bytes[p])) ++p;
    XmlElement el;
    el.name = bytes.substr(name_begin, p - name_begin);
    el.offset = pos;
    el.parent = stack.empty() ? -1 : stack.back();
    if (el.name.empty()) return err(pos, "expected an element name after '<'");
    bool self_closing = false;
    for (;;) {
      while (p < bytes.size() && is_space(bytes[p])) ++p;
      if (p >= bytes.size()) return err(pos, "file ends inside the tag <" + std::string(el.name) + ">");
      if (bytes[p] == '>') {
        ++p;
        break;
      }
      if (bytes[p] == '/') {
        if (p + 1 >= bytes.size() || bytes[p + 1] != '>') return err(p, "expected '/>'");
        self_closing = true;
        p += 2;
        break;
      }
      const std::size_t attr_begin = p;
      while (p < bytes.size() && is_name_char(bytes[p])) ++p;
      const std::string_view attr = bytes.substr(attr_begin, p - attr_begin);
      if (attr.empty())
        return err(
            p, "unexpected character " + quote_token(bytes.substr(p, 1)) + " in tag <" + std::string(el.name) + ">");
      while (p < bytes.size() && is_space(bytes[p])) ++p;
      if (p >= bytes.size() || bytes[p] != '=') return err(p, "expected '=' after attribute " + quote_token(attr));
      ++p;
      while (p < bytes.size() && is_space(bytes[p])) ++p;
      if (p >= bytes.size() || (bytes[p] != '"' && bytes[p] != '\''))
        return err(p, "expected a quoted value for attribute " + quote_token(attr));
      const char quote = bytes[p++];
      const std::size_t value_end = bytes.find(quote, p);
      if (value_end == std::string_view::npos) return err(p, "unterminated value of attribute " + quote_token(attr));
      const std::string_view raw = bytes.substr(p, value_end - p);
      if (raw.find('<') != std::string_view::npos)
        return err(p, "'<' inside the value of attribute " + quote_token(attr));
      XmlAttribute a;
      a.name = attr;
      if (!decode_entities(raw, a.value)) return err(p, "bad character reference in attribute " + quote_token(attr));
      if (el.attribute(attr)) return err(attr_begin, "attribute " + quote_token(attr) + " appears twice");
      el.attributes.push_back(std::move(a));
      p = value_end + 1;
    }
    el.content_begin = p;
    el.content_end = p;
    const int index = static_cast<int>(doc.elements.size());
    if (!stack.empty()) doc.elements[static_cast<std::size_t>(stack.back())].child_indices.push_back(index);
    doc.elements.push_back(std::move(el));
    if (!self_closing) {
      if (static_cast<int>(stack.size()) >= kMaxDepth)
        return err(pos, "elements nested deeper than " + std::to_string(kMaxDepth));
      stack.push_back(index);
    } else if (stack.empty()) {
      root_closed = true;
    }
    pos = p;
  }
  if (!stack.empty())
    return err(bytes.size(),
               "file ends inside <" + std::string(doc.elements[static_cast<std::size_t>(stack.back())].name) + ">");
  if (doc.elements.empty()) return err(pos, "no XML element in the file");
  return doc;
}

}  // namespace shatter::io
