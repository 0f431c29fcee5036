// Programmer-error checks with an overridable handler (in the manner of Box2D's b2SetAssertFcn).
// SHATTER_ASSERT is active unless NDEBUG; SHATTER_CHECK is always active (cheap, vital checks).
#pragma once

namespace shatter {

/// Called when an assertion fails. Return true to break into the debugger / abort (default).
using AssertHandler = bool (*)(const char* condition, const char* file, int line);
void set_assert_handler(AssertHandler handler);
[[noreturn]] void assert_failed(const char* condition, const char* file, int line);

}  // namespace shatter

#define SHATTER_CHECK(cond) ((cond) ? static_cast<void>(0) : ::shatter::assert_failed(#cond, __FILE__, __LINE__))
#ifdef NDEBUG
#define SHATTER_ASSERT(cond) static_cast<void>(0)
#else
#define SHATTER_ASSERT(cond) SHATTER_CHECK(cond)
#endif
