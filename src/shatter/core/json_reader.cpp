// Strict JSON reading with file + field-path errors (see json_reader.h).
#include "shatter/core/json_reader.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace shatter::json_input {
namespace {

// A finite number; `expected` names what the caller wants ("a number > 0") so that a value of the
// wrong type is told the whole expectation, not only "a number".
Result<double> read_finite(const Json& value, const Where& where, const char* expected) {
  if (!value.is_number()) return where.error(std::string("expected ") + expected + ", got " + type_name(value));
  const double v = value.get<double>();
  if (!std::isfinite(v)) return where.error("expected a finite number");
  return v;
}

// [c0, c1, ...] of exactly N values, each read by `component` at "path[k]"; `shape` is how the
// array is described in messages ("[x, y, z]").
template <int N, class Component>
Result<Eigen::Matrix<double, N, 1>> read_fixed(const Json& value, const Where& where, const char* shape,
                                               Component component) {
  if (!value.is_array() || value.size() != static_cast<std::size_t>(N))
    return where.error("expected an array of " + std::to_string(N) + " numbers " + shape + ", got " +
                       (value.is_array() ? "an array of " + std::to_string(value.size()) : type_name(value)));
  Eigen::Matrix<double, N, 1> v;
  for (std::size_t k = 0; k < static_cast<std::size_t>(N); ++k) {
    SHATTER_TRY(c, component(value[k], where.index(k)));
    v[static_cast<Eigen::Index>(k)] = *c;
  }
  return v;
}

}  // namespace

Where Where::key(std::string_view k) const {
  Where w{file, path};
  if (!w.path.empty()) w.path += ".";
  w.path += k;
  return w;
}

Where Where::index(std::size_t i) const { return Where{file, path + "[" + std::to_string(i) + "]"}; }

Error Where::error(std::string message) const {
  Error e = field_error(path.empty() ? std::string("(top level)") : path, std::move(message));
  if (file) e.file = *file;
  return e;
}

Result<Json> parse_json(std::string_view text, const std::string& file) {
  // Nesting bounded before parsing: the readers of shapes, cases and scenes walk the tree
  // recursively, so a file of 10,000 nested objects must be an error, not a stack overflow.
  {
    int depth = 0;
    bool in_string = false;
    std::int64_t line = 1;
    for (std::size_t i = 0; i < text.size(); ++i) {
      const char c = text[i];
      if (c == '\n') ++line;
      if (in_string) {
        if (c == '\\')
          ++i;  // skip the escaped character (an escaped newline is invalid JSON anyway)
        else if (c == '"')
          in_string = false;
      } else if (c == '"') {
        in_string = true;
      } else if (c == '{' || c == '[') {
        if (++depth > kMaxJsonDepth)
          return line_error(
              file, line, "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels of objects and arrays");
      } else if (c == '}' || c == ']') {
        --depth;  // unbalanced brackets are the parser's to report
      }
    }
  }
  // Duplicate keys are errors (nlohmann would silently keep the last value): each open object
  // keeps the keys seen so far, and the path of the first repeat is kept for the message.
  struct Frame {
    bool object = false;
    std::vector<std::string> keys;  // object: keys seen
    std::string current;            // object: the key being read; array: "[i]" of the element
    std::size_t count = 0;          // array: elements so far
  };
  std::vector<Frame> frames;
  std::string duplicate;  // path of the first repeated key, "" if none
  auto path = [&] {
    std::string out;
    for (const Frame& f : frames) {
      if (f.current.empty()) continue;
      if (f.object && !out.empty()) out += '.';
      out += f.current;
    }
    return out;
  };
  auto element = [&] {  // a value or a container starts in an array: name its index
    if (!frames.empty() && !frames.back().object)
      frames.back().current = "[" + std::to_string(frames.back().count++) + "]";
  };
  const Json::parser_callback_t track = [&](int, Json::parse_event_t event, Json& parsed) {
    switch (event) {
      case Json::parse_event_t::object_start:
      case Json::parse_event_t::array_start:
        element();
        frames.push_back(Frame{event == Json::parse_event_t::object_start, {}, {}, 0});
        break;
      case Json::parse_event_t::object_end:
      case Json::parse_event_t::array_end:
        if (!frames.empty()) frames.pop_back();
        break;
      case Json::parse_event_t::key:
        if (!frames.empty() && parsed.is_string()) {
          Frame& f = frames.back();
          f.current = parsed.get<std::string>();
          if (std::find(f.keys.begin(), f.keys.end(), f.current) != f.keys.end()) {
            if (duplicate.empty()) duplicate = path();
          } else {
            f.keys.push_back(f.current);
          }
        }
        break;
      case Json::parse_event_t::value: element(); break;
    }
    return true;
  };
  try {
    Json doc = Json::parse(text.begin(), text.end(), track);
    if (!duplicate.empty())
      return file_error(file, "duplicate key " + duplicate + ": each key may appear once in an object");
    return doc;
  } catch (const Json::parse_error& e) {
    // Turn the byte position into a line number.
    const std::size_t byte = std::min<std::size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    const std::int64_t line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(byte), '\n');
    std::string what = e.what();
    // nlohmann's text: "[json.exception.parse_error.101] parse error at line 3, column 5: ..."
    const std::size_t colon = what.find(": ");
    if (colon != std::string::npos) what = what.substr(colon + 2);
    return line_error(file, line, "invalid JSON: " + what);
  } catch (const std::exception& e) {
    // e.g. "[json.exception.out_of_range.406] number overflow parsing '1e400'": without the tag.
    std::string what = e.what();
    if (what.rfind("[json.exception.", 0) == 0 && what.find("] ") != std::string::npos)
      what = what.substr(what.find("] ") + 2);
    return file_error(file, "invalid JSON: " + what);
  }
}

std::string type_name(const Json& value) {
  switch (value.type()) {
    case Json::value_t::null: return "null";
    case Json::value_t::object: return "an object";
    case Json::value_t::array: return "an array";
    case Json::value_t::string: return "a string (\"" + value.get<std::string>() + "\")";
    case Json::value_t::boolean: return value.get<bool>() ? "true" : "false";
    case Json::value_t::number_integer:
    case Json::value_t::number_unsigned:
    case Json::value_t::number_float: return "the number " + value.dump();
    default: return "an unsupported value";
  }
}

ObjectReader::ObjectReader(const Json& value, Where where) : object_(&value), where_(std::move(where)) {
  if (!value.is_object()) status_ = where_.error("expected an object, got " + type_name(value));
}

const Json* ObjectReader::get(std::string_view key) {
  known_.emplace_back(key);
  if (!object_->is_object()) return nullptr;
  const auto it = object_->find(std::string(key));
  return it == object_->end() ? nullptr : &*it;
}

void ObjectReader::allow(std::initializer_list<std::string_view> keys) {
  for (std::string_view k : keys) known_.emplace_back(k);
}

bool ObjectReader::has(std::string_view key) const {
  return object_->is_object() && object_->contains(std::string(key));
}

Result<void> ObjectReader::finish() const {
  if (!status_.ok()) return status_;
  for (auto it = object_->begin(); it != object_->end(); ++it) {
    if (std::find(known_.begin(), known_.end(), it.key()) != known_.end()) continue;
    std::string message = "unknown key \"" + it.key() + "\"";
    const std::string guess = nearest(it.key(), known_);
    if (!guess.empty()) message += " (did you mean \"" + guess + "\"?)";
    std::vector<std::string> sorted = known_;
    std::sort(sorted.begin(), sorted.end());
    sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
    message += "; known keys:";
    for (const std::string& k : sorted) message += " " + k;
    return where_.key(it.key()).error(message);
  }
  return {};
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t subst = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, subst});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string nearest(std::string_view word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = std::numeric_limits<std::size_t>::max();
  for (const std::string& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  // A likely typo: at most a third of the word's letters differ (and at least one may).
  const std::size_t limit = std::max<std::size_t>(1, word.size() / 3);
  if (best_d <= limit) return best;
  // An abbreviation ("tol" for "tolerance").
  if (word.size() >= 3)
    for (const std::string& c : candidates)
      if (c.size() > word.size() && c.compare(0, word.size(), word) == 0) return c;
  return std::string();
}

Result<double> read_number(const Json& value, const Where& where) { return read_finite(value, where, "a number"); }

Result<double> read_positive(const Json& value, const Where& where) {
  SHATTER_TRY(v, read_finite(value, where, "a number > 0"));
  if (!(*v > 0.0)) return where.error("expected a number > 0, got " + value.dump());
  return *v;
}

Result<double> read_non_negative(const Json& value, const Where& where) {
  SHATTER_TRY(v, read_finite(value, where, "a number >= 0"));
  if (*v < 0.0) return where.error("expected a number >= 0, got " + value.dump());
  return *v;
}

Result<std::int64_t> read_integer(const Json& value, const Where& where) {
  if (value.is_number_integer()) return value.get<std::int64_t>();
  if (value.is_number_unsigned()) {
    const auto u = value.get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
      return where.error("integer " + value.dump() + " is too large");
    return static_cast<std::int64_t>(u);
  }
  return where.error("expected an integer, got " + type_name(value));
}

Result<bool> read_bool(const Json& value, const Where& where) {
  if (!value.is_boolean()) return where.error("expected true or false, got " + type_name(value));
  return value.get<bool>();
}

Result<std::string> read_string(const Json& value, const Where& where) {
  if (!value.is_string()) return where.error("expected a string, got " + type_name(value));
  std::string s = value.get<std::string>();
  // A NUL ("\u0000") would cut the name short in messages and in the file names made from it.
  if (s.find('\0') != std::string::npos) return where.error("expected a string without NUL characters (\\u0000)");
  return s;
}

Result<Vec2> read_vec2(const Json& value, const Where& where) {
  return read_fixed<2>(value, where, "[x, y]", read_number);
}

Result<Vec3> read_vec3(const Json& value, const Where& where) {
  return read_fixed<3>(value, where, "[x, y, z]", read_number);
}

Result<Vec3> read_positive_vec3(const Json& value, const Where& where) {
  return read_fixed<3>(value, where, "[x, y, z]", read_positive);
}

Result<const Json*> read_array(const Json& value, const Where& where) {
  if (!value.is_array()) return where.error("expected an array, got " + type_name(value));
  return &value;
}

}  // namespace shatter::json_input
