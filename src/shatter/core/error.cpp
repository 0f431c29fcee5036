#include "shatter/core/error.h"

#include <cstdio>

namespace shatter {

std::string Error::to_string() const {
  std::string s;
  if (!file.empty()) {
    s += file;
    if (line >= 0) s += ":" + std::to_string(line);
    s += ": ";
    if (line < 0 && offset >= 0) s += "byte " + std::to_string(offset) + ": ";
  } else if (offset >= 0) {
    s += "byte " + std::to_string(offset) + ": ";
  }
  if (!field.empty()) s += field + ": ";
  s += message;
  return s;
}

Error make_error(std::string message) { return Error{.message = std::move(message)}; }
Error file_error(std::string file, std::string message) {
  return Error{.message = std::move(message), .file = std::move(file)};
}
Error line_error(std::string file, std::int64_t line, std::string message) {
  return Error{.message = std::move(message), .file = std::move(file), .line = line};
}
Error offset_error(std::string file, std::int64_t offset, std::string message) {
  return Error{.message = std::move(message), .file = std::move(file), .offset = offset};
}
Error field_error(std::string field, std::string message) {
  return Error{.message = std::move(message), .field = std::move(field)};
}

std::string format_number(double v, int digits) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

}  // namespace shatter
