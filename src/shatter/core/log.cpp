#include "shatter/core/log.h"

#include <cstdio>
#include <mutex>
#include <string>

namespace shatter {
namespace {
void default_sink(LogLevel level, std::string_view message) {
  if (level < LogLevel::warning) return;
  std::fprintf(stderr, "%s: %.*s\n", level == LogLevel::warning ? "warning" : "error", static_cast<int>(message.size()),
               message.data());
}
LogSink& sink() {
  static LogSink s = default_sink;
  return s;
}
std::mutex& sink_mutex() {
  static std::mutex m;
  return m;
}
}  // namespace

LogSink set_log_sink(LogSink new_sink) {
  LogSink old = std::move(sink());
  sink() = new_sink ? std::move(new_sink) : LogSink(default_sink);
  return old;
}

void log_message(LogLevel level, std::string_view message) {
  std::lock_guard lock(sink_mutex());
  sink()(level, message);
}

}  // namespace shatter
