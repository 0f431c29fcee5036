// Which instructions the vector kernels use (the FEM force kernels, the batched contact solver).
// Each kernel is compiled twice from one source: for the build's baseline (SSE on x86-64-v2) and for
// AVX2. Both do the same operations in the same order with none fused (-ffp-contract=off), so they
// give the same bits; the choice only changes the speed.
#pragma once

namespace shatter {

/// The instruction set of the vector kernels.
enum class SimdIsa { baseline, avx2 };

/// By default AVX2 where the CPU has it. Process-wide; for checking and timing. Asking for avx2 on a
/// CPU without it gives baseline.
void set_simd_isa(SimdIsa isa);

/// The instruction set the kernels use now.
[[nodiscard]] SimdIsa simd_isa();

}  // namespace shatter
