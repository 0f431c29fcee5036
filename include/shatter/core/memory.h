// Process-wide allocator settings for simulation (docs/api.md, "Memory").
//
// An impact step allocates and frees arrays of 0.1-10 MB (element matrices, sparse patterns, the
// symbolic analysis, cut meshes). By default glibc's allocator hands such blocks back to the
// system when they are freed (mmap above a threshold, trimming the heap's top), so the next step
// takes page faults on fresh pages again: measured, about a fifth of a cinder block's breaking
// step (docs/performance.md, "2026-12-03").
// Keeping freed memory in the process removes that cost; the process then holds its peak heap.
// A library must not change process-wide settings on its own: programs call this at start-up
// (shatter's command-line tools and benchmarks do).
#pragma once

namespace shatter {

/// Ask the C library's allocator to keep freed memory for the next allocations instead of
/// returning it to the system: with glibc, blocks below 32 MiB come from the heap (M_MMAP_THRESHOLD)
/// and the heap is trimmed only above 1 GiB of free memory at its top (M_TRIM_THRESHOLD), in the
/// main and the threads' arenas. Call it once, before the threads start. Returns false, changing
/// nothing, where the allocator has no such settings (not glibc).
bool keep_freed_memory();

}  // namespace shatter
