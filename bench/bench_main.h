// The benchmarks' main: the allocator settings of shatter's programs (core/memory.h), then Google
// Benchmark's own main.
#pragma once

#include <benchmark/benchmark.h>

#include "shatter/core/memory.h"

#define SHATTER_BENCHMARK_MAIN()                                      \
  int main(int argc, char** argv) {                                   \
    shatter::keep_freed_memory();                                     \
    benchmark::Initialize(&argc, argv);                               \
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1; \
    benchmark::RunSpecifiedBenchmarks();                              \
    benchmark::Shutdown();                                            \
    return 0;                                                         \
  }
