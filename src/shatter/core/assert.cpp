#include "shatter/core/assert.h"

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace shatter {
namespace {
bool default_handler(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "shatter: assertion failed: %s (%s:%d)\n", condition, file, line);
  return true;
}
AssertHandler g_handler = &default_handler;
}  // namespace

void set_assert_handler(AssertHandler handler) { g_handler = handler ? handler : &default_handler; }

void assert_failed(const char* condition, const char* file, int line) {
  if (g_handler(condition, file, line)) std::abort();
  // A handler that returns false asks to continue: throw so the caller's state stays unwound.
  throw std::logic_error(std::string("assertion failed: ") + condition);
}

}  // namespace shatter
