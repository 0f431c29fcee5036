// Warnings and notes from the library go through one replaceable sink, so that applications
// decide where they go (the CLI prints them on stderr; tests fail on unexpected ones).
#pragma once

#include <functional>
#include <string_view>

namespace shatter {

/// Severity of a message.
enum class LogLevel { debug, info, warning, error };

/// Receives every message with its level.
using LogSink = std::function<void(LogLevel, std::string_view)>;

/// Replace the sink (an empty function restores the default: warnings and errors to stderr).
/// Returns the previous sink. Not thread-safe: set it once at start-up.
LogSink set_log_sink(LogSink sink);
/// Pass a message to the sink (one call at a time: safe from any thread).
void log_message(LogLevel level, std::string_view message);
/// log_message at warning level.
inline void log_warning(std::string_view message) { log_message(LogLevel::warning, message); }
/// log_message at info level.
inline void log_info(std::string_view message) { log_message(LogLevel::info, message); }

}  // namespace shatter
