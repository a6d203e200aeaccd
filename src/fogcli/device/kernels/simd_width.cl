/* How many floats a SIMD register holds in the code this compiler emits for the device:
 * the target's own feature macros. The host picks LANES by it (runtime.Runtime.lanes):
 * what the device reports can differ (PoCL 3.0's LLVM 14 compiles for znver3, AVX2, on
 * a Zen 4, which the device reports as 16 floats wide). 0: the compiler does not say. */
__kernel void simd_width(__global int *out)
{
#if defined(__AVX512F__)
    out[0] = 16;
#elif defined(__AVX__)
    out[0] = 8;
#elif defined(__SSE2__)
    out[0] = 4;
#else
    out[0] = 0;
#endif
}
