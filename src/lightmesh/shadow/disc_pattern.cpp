// disc_pattern.cpp -- the golden-ratio lattice on the disc and the cone to a sphere.
//
// Sample k of n is the point ((k + ½)/n, frac(k·(φ − 1))) of the golden-ratio lattice in
// [0, 1)² (optionally shifted modulo 1), mapped to the unit disc by Shirley and Chiu's
// concentric map (pbrt-v4 SampleUniformDiskConcentric), which keeps strata compact and is
// area-preserving, and the disc to the cone by 1 − cos θ = r²·(1 − cos θmax), φ = the
// disc's angle, also measure-preserving (dΩ = d(cos θ) dφ). So n directions are uniform in
// solid angle and evenly spread; for a penumbra (a visibility edge across the cone) the
// error falls like n^-3/4 rather than n^-1/2.
#include "lightmesh/shadow/disc_pattern.h"

#include <algorithm>
#include <cmath>

namespace lm {

namespace {
constexpr float OneMinusEpsilon = 0x1.fffffep-1f;
}  // namespace

void ConcentricDisc(float u0, float u1, float* dx, float* dy) {
    const float ox = 2.0f * u0 - 1.0f, oy = 2.0f * u1 - 1.0f;
    *dx = *dy = 0;
    if (ox == 0 && oy == 0) return;
    float r, theta;
    if (std::abs(ox) > std::abs(oy)) {
        r = ox;
        theta = (Pi / 4) * (oy / ox);
    } else {
        r = oy;
        theta = Pi / 2 - (Pi / 4) * (ox / oy);
    }
    *dx = r * std::cos(theta);
    *dy = r * std::sin(theta);
}

void GoldenLattice(int k, int n, double shift0, double shift1, float* u0, float* u1) {
    constexpr double GoldenFraction = 0.61803398874989484820;  // φ − 1
    double a = (k + 0.5) / n + shift0;
    double b = k * GoldenFraction + shift1;
    a -= std::floor(a);
    b -= std::floor(b);
    *u0 = std::min(static_cast<float>(a), OneMinusEpsilon);
    *u1 = std::min(static_cast<float>(b), OneMinusEpsilon);
}

DiscPattern DiscPattern::Golden(int n, int passes) {
    DiscPattern d;
    d.passes = passes;
    d.x.resize(n), d.y.resize(n), d.r2.resize(n);
    const int perPass = n / passes;
    for (int k = 0; k < n; ++k) {
        float u0, u1;
        GoldenLattice(k, n, 0.0, 0.0, &u0, &u1);
        const int at = (k % passes) * perPass + k / passes;
        ConcentricDisc(u0, u1, &d.x[at], &d.y[at]);
        d.r2[at] = d.x[at] * d.x[at] + d.y[at] * d.y[at];
    }
    return d;
}

DiscTurns::DiscTurns() {
    for (int t = 0; t < kDiscTurns; ++t) {
        cs[t] = std::cos((static_cast<float>(t) + 0.5f) * (2 * Pi / kDiscTurns));
        sn[t] = std::sin((static_cast<float>(t) + 0.5f) * (2 * Pi / kDiscTurns));
    }
}

const DiscTurns& DiscTurns::Get() {
    static const DiscTurns turns;
    return turns;
}

SphereCone::SphereCone(const Vec3& origin, const Vec3& center, float radius)
    : origin_(origin), oc_(center - origin), r2_(radius * radius) {
    const float d2 = LengthSquared(oc_);
    inside_ = d2 <= r2_;
    if (inside_) return;
    d_ = std::sqrt(d2);
    axis_ = oc_ / d_;
    // 1 − cos θmax without cancellation: sin²/(1 + cos), sin² θmax = R²/d².
    const float sin2 = r2_ / d2, cos = std::sqrt(std::max(0.0f, 1.0f - sin2));
    oneMinusCosMax_ = sin2 / (1.0f + cos);
    tan_ = cos > 0 ? std::sqrt(sin2) / cos : Infinity;
    CoordinateSystem(axis_, &e1_, &e2_);
    f1_ = e1_, f2_ = e2_;
}

void SphereCone::Turn(int turn) {
    const DiscTurns& t = DiscTurns::Get();
    const float cs = t.cs[turn & (kDiscTurns - 1)], sn = t.sn[turn & (kDiscTurns - 1)];
    f1_ = e1_ * cs + e2_ * sn;
    f2_ = e2_ * cs - e1_ * sn;
}

Ray SphereCone::RayAlong(const Vec3& w) const {
    // The near intersection with the sphere, from the perpendicular distance of the centre
    // to the ray (stabler than b² − c); rounding at the cone's rim is clamped to the tangent.
    const float b = Dot(w, oc_);
    const float h2 = r2_ - LengthSquared(oc_ - w * b);
    const float t = b - std::sqrt(std::max(0.0f, h2));
    return Ray{origin_, w * t, 0.0f, 1.0f - 1e-5f};
}

}  // namespace lm
