// A small non-validating XML tokenizer for VTK XML files: elements, attributes, and the raw byte
// range of each element's content. No DTDs or entity definitions (refused), no recursion, bounded
// depth; every error names the file and line.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "shatter/core/error.h"

namespace shatter::io {

struct XmlAttribute {
  std::string_view name;
  std::string value;  ///< with &lt; &gt; &amp; &quot; &apos; and &#N; decoded
};

struct XmlElement {
  std::string_view name;
  std::vector<XmlAttribute> attributes;
  int parent = -1;                ///< index in XmlDocument::elements, -1 for the root
  std::size_t offset = 0;         ///< byte offset of its '<'
  std::size_t content_begin = 0;  ///< byte range between the start and end tags
  std::size_t content_end = 0;
  std::vector<int> child_indices;  ///< direct children, in document order
  /// The attribute's value, or nullptr.
  [[nodiscard]] const std::string* attribute(std::string_view attr_name) const;
};

struct XmlDocument {
  std::vector<XmlElement> elements;  ///< in document order; elements[0] is the root
  /// Indices of the direct children of `parent` named `name` (any name if empty); time linear in
  /// the number of children.
  [[nodiscard]] std::vector<int> children(int parent, std::string_view name = {}) const;
};

Result<XmlDocument> parse_xml(std::string_view bytes, const std::string& name);

/// 1-based line of a byte offset.
std::int64_t line_of(std::string_view bytes, std::size_t offset);

/// Escape & < > " ' for an attribute value or text.
std::string xml_escape(std::string_view s);

}  // namespace shatter::io
