// Programmer-error checks with an overridable handler (in the manner of Box2D's b2SetAssertFcn).
// SHATTER_ASSERT is active unless NDEBUG; SHATTER_CHECK is always active (cheap, vital checks).
#pragma once

namespace shatter {

/// Called when an assertion fails. Return true to abort (the default handler prints and aborts),
/// false to throw std::logic_error instead.
using AssertHandler = bool (*)(const char* condition, const char* file, int line);
/// Install `handler` (nullptr restores the default).
void set_assert_handler(AssertHandler handler);
/// Report a failed check to the handler, then abort or throw (what the macros below call).
[[noreturn]] void assert_failed(const char* condition, const char* file, int line);

}  // namespace shatter

/// Always-active check: calls assert_failed when `cond` is false.
#define SHATTER_CHECK(cond) ((cond) ? static_cast<void>(0) : ::shatter::assert_failed(#cond, __FILE__, __LINE__))
/// Debug-only check: SHATTER_CHECK unless NDEBUG, else nothing (`cond` is not evaluated).
#ifdef NDEBUG
#define SHATTER_ASSERT(cond) static_cast<void>(0)
#else
#define SHATTER_ASSERT(cond) SHATTER_CHECK(cond)
#endif
