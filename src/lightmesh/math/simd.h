// simd.h -- W-lane float and int vectors (GCC/clang vector extensions) for the loops that
// test one ray or segment against several triangles at once: 4 lanes (SSE, the x86-64
// baseline) or 8 (AVX2, in functions compiled for it and chosen at run time).
#pragma once

namespace lm {

template <int W>
struct SimdVectors;
template <>
struct SimdVectors<4> {
    typedef float F __attribute__((vector_size(16)));
    typedef int I __attribute__((vector_size(16)));
};
template <>
struct SimdVectors<8> {
    typedef float F __attribute__((vector_size(32)));
    typedef int I __attribute__((vector_size(32)));
};

}  // namespace lm
