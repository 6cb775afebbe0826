// light_terms.cpp -- the lights' terms at a shading point, W lights at a time.
#include "lightmesh/render/light_terms.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

#include "lightmesh/math/simd.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace {

// For each mask of 8 lanes, its set lanes in ascending order, then zeros: the permutation
// that packs the lit lanes to the front.
struct PackLanes {
    uint8_t lanes[256][8] = {};
};
constexpr PackLanes MakePackLanes() {
    PackLanes t;
    for (int m = 0; m < 256; ++m)
        for (int k = 0, n = 0; k < 8; ++k)
            if (m >> k & 1) t.lanes[m][n++] = static_cast<uint8_t>(k);
    return t;
}
alignas(64) constexpr PackLanes kPackLanes = MakePackLanes();

// The evaluation for 4 lanes (SSE, the x86-64 baseline) and 8 (AVX2, compiled for it with
// a target attribute on each definition and chosen at run time): one body,
// light_terms_lanes.inc, in a namespace per width.
namespace lanes4 {
#define LM_TERMS_LANES 4
#define LM_TERMS_TARGET
#include "lightmesh/render/light_terms_lanes.inc"
#undef LM_TERMS_LANES
#undef LM_TERMS_TARGET
}  // namespace lanes4
#if defined(__x86_64__) || defined(__i386__)
namespace lanes8 {
#define LM_TERMS_LANES 8
#define LM_TERMS_TARGET __attribute__((target("avx2")))
#include "lightmesh/render/light_terms_lanes.inc"
#undef LM_TERMS_LANES
#undef LM_TERMS_TARGET
}  // namespace lanes8
bool CanRun8() { return __builtin_cpu_supports("avx2"); }
uint32_t Evaluate8(const LightTerms::Arrays& a, uint32_t total, const LightTermPoint& pt, const uint32_t* ids,
                   Color* omega, uint32_t* lit) {
    return lanes8::Evaluate(a, total, pt, ids, omega, lit);
}
#else
bool CanRun8() { return false; }
uint32_t Evaluate8(const LightTerms::Arrays& a, uint32_t total, const LightTermPoint& pt, const uint32_t* ids,
                   Color* omega, uint32_t* lit) {
    return lanes4::Evaluate(a, total, pt, ids, omega, lit);
}
#endif

}  // namespace

LightTerms::LightTerms(const std::vector<PointLight>& lights, int width) {
    if (width != 0 && width != 4 && width != 8) ThrowError("light terms: %d lanes (4 or 8)", width);
    if (width == 8 && !CanRun8()) ThrowError("light terms: 8 lanes need AVX2, which this CPU lacks");
    width_ = width ? width : (CanRun8() ? 8 : 4);
    if (lights.size() > UINT32_MAX - 8) ThrowError("light terms: %zu lights (at most 2^32 - 8)", lights.size());
    count_ = lights.size();
    // Padded by 8 beyond the last light: a run of W lights loaded from any light's index
    // stays inside (the lanes past the last light are masked).
    const size_t padded = (count_ + 7) / 8 * 8 + 8;
    for (auto* v : {&a_.x, &a_.y, &a_.z, &a_.range2, &a_.r, &a_.g, &a_.b}) v->assign(padded, 0.0f);
    a_.inverseSquare.assign(padded, 0);
    for (size_t i = 0; i < count_; ++i) {
        const PointLight& l = lights[i];
        a_.x[i] = l.position.x, a_.y[i] = l.position.y, a_.z[i] = l.position.z;
        a_.range2[i] = l.range * l.range;
        a_.r[i] = l.intensity.r, a_.g[i] = l.intensity.g, a_.b[i] = l.intensity.b;
        a_.inverseSquare[i] = l.falloff == Falloff::InverseSquare ? -1 : 0;
    }
    cones_.resize(count_);
    isSpot_.assign(count_, 0);
    for (size_t i = 0; i < count_; ++i) {
        if (lights[i].kind != LightKind::Spot) continue;
        cones_[i] = lights[i].spot;
        isSpot_[i] = 1;
        anySpot_ = true;
    }
    a_.records.resize(8 * count_);
    for (size_t i = 0; i < count_; ++i) {
        float* r = &a_.records[8 * i];
        r[0] = a_.x[i], r[1] = a_.y[i], r[2] = a_.z[i], r[3] = a_.range2[i];
        r[4] = a_.r[i], r[5] = a_.g[i], r[6] = a_.b[i];
        std::memcpy(&r[7], &a_.inverseSquare[i], sizeof(float));
    }
}

uint32_t LightTerms::All(const LightTermPoint& point, Color* omega, uint32_t* lit) const {
    const uint32_t n = static_cast<uint32_t>(count_);
    const uint32_t count = width_ == 8 ? Evaluate8(a_, n, point, nullptr, omega, lit)
                                       : lanes4::Evaluate(a_, n, point, nullptr, omega, lit);
    return anySpot_ ? ApplyCones(point, omega, lit, count) : count;
}

uint32_t LightTerms::Listed(const LightTermPoint& point, const uint32_t* ids, uint32_t count, Color* omega,
                            uint32_t* lit) const {
    if (count == 0) return 0;
    const uint32_t litCount = width_ == 8 ? Evaluate8(a_, count, point, ids, omega, lit)
                                          : lanes4::Evaluate(a_, count, point, ids, omega, lit);
    return anySpot_ ? ApplyCones(point, omega, lit, litCount) : litCount;
}

// After the lanes: only scenes with a spot pay for it, once per lit light (the direction
// to the light recomputed as the lanes computed it).
uint32_t LightTerms::ApplyCones(const LightTermPoint& point, Color* omega, uint32_t* lit, uint32_t count) const {
    uint32_t kept = 0;
    for (uint32_t k = 0; k < count; ++k) {
        const uint32_t i = lit[k];
        Color o = omega[k];
        if (isSpot_[i]) {
            const Vec3 toLight = Vec3(a_.x[i], a_.y[i], a_.z[i]) - point.p;
            const float factor = cones_[i].Factor(toLight * (1.0f / std::sqrt(LengthSquared(toLight))));
            if (!(factor > 0)) continue;
            o = o * factor;
        }
        omega[kept] = o;
        lit[kept] = i;
        ++kept;
    }
    return kept;
}

}  // namespace lm
