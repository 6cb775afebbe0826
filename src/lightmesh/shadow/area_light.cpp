// area_light.cpp -- spherical lights sampled with stratified shadow rays.
//
// Estimator. For a light of centre C and radius R seen from P at distance d > R, the sphere
// covers the cone of half-angle θmax, sin θmax = R/d. V(P) = the fraction of that cone's
// solid angle whose rays reach the sphere unblocked; it is estimated as the fraction of N
// unblocked rays with directions uniform in solid angle over the cone (pbrt-v4's
// SampleUniformCone, src/pbrt/util/sampling.h). This is the "naive" soft shadow of the
// paper's §1.2, and V multiplies Ω(i, P) evaluated at the light's centre, exactly where the
// light mesh method's interpolated V goes, so the two images differ only in their shadows.
//
// Stratification. Sample i of N is the point ((i + ½)/N, frac(i·(φ − 1))) of the golden-ratio
// (Fibonacci-type) lattice in [0, 1)², shifted modulo 1 by a random offset (Cranley–Patterson
// rotation). The lattice is mapped to the unit disc by Shirley and Chiu's concentric map
// (pbrt-v4 SampleUniformDiskConcentric), which keeps strata compact and is area-preserving,
// and the disc to the cone by 1 − cos θ = r²·(1 − cos θmax), φ = the disc's angle, which is
// also measure-preserving (dΩ = d(cos θ) dφ). So the N directions are uniform in solid angle
// and evenly spread; for a penumbra (a visibility edge across the cone) the error falls
// like N^-3/4 rather than N^-1/2.
//
// Determinism. The offset comes from a hash (SplitMix64's finaliser) of the bits of the
// shading point, its triangle and the light's index: the estimate is a function of the
// point alone, so images do not depend on threads, tile order or pixel.
#include "lightmesh/shadow/area_light.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <utility>

#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/hash.h"

namespace lm {

namespace {

/// A float in [0, 1) from 24 bits.
constexpr float UnitFloat(uint64_t bits24) { return static_cast<float>(bits24 & 0xFFFFFF) * 0x1p-24f; }


}  // namespace

void ValidateAreaLightOptions(const AreaLightOptions& o) {
    if (o.radius && !(std::isfinite(*o.radius) && *o.radius >= 0))
        ThrowSettingError("light_radius", "light radius %g: must be a finite number >= 0", static_cast<double>(*o.radius));
    if (o.samples < 1 || o.samples > 4096)
        ThrowSettingError("samples", "area-light samples %d: must be 1 to 4096", o.samples);
}

uint64_t AreaLightSeed(const ShadingPoint& sp, uint32_t light, uint32_t stream) {
    uint64_t h = Mix64(0x9E3779B97F4A7C15ull + (light | uint64_t(stream) << 32));
    h = Mix64(h ^ (std::bit_cast<uint32_t>(sp.p.x) | uint64_t(std::bit_cast<uint32_t>(sp.p.y)) << 32));
    h = Mix64(h ^ (std::bit_cast<uint32_t>(sp.p.z) | uint64_t(sp.prim) << 32));
    return h;
}


namespace {

/// Direction `index` of `samples`: the golden-ratio lattice point shifted by (shift0,
/// shift1), on the disc, mapped to the cone (disc_pattern.h).
Vec3 SampleCone(const SphereCone& cone, int index, int samples, float shift0, float shift1) {
    float u0, u1, dx, dy;
    GoldenLattice(index, samples, shift0, shift1, &u0, &u1);
    ConcentricDisc(u0, u1, &dx, &dy);
    return cone.Direction(dx, dy, dx * dx + dy * dy);
}

}  // namespace

Vec3 SampleConeStratified(const Vec3& axis, float oneMinusCosMax, int index, int samples,
                          float shift0, float shift1) {
    float u0, u1, dx, dy;
    GoldenLattice(index, samples, shift0, shift1, &u0, &u1);
    ConcentricDisc(u0, u1, &dx, &dy);
    Vec3 e1, e2;
    CoordinateSystem(axis, &e1, &e2);
    return ConeDirection(e1, e2, axis, oneMinusCosMax, dx, dy, dx * dx + dy * dy);
}

// Rays handed to Accelerator::OccludedMany at once: Embree's widest packet here (8, AVX2).
constexpr int kRayBatch = 8;

SphereLightRays::SphereLightRays(const Vec3& origin, const Vec3& center, float radius, int samples, uint64_t seed)
    : cone_(origin, center, radius), samples_(samples) {
    shift0_ = UnitFloat(seed >> 40);
    shift1_ = UnitFloat(seed >> 8);
}

Ray SphereLightRays::Get(int index) const {
    // Like LightVisible, the ray stops just short of the light itself.
    return cone_.RayAlong(SampleCone(cone_, index, samples_, shift0_, shift1_));
}

float SphereLightVisibility(const Accelerator& accel, const Vec3& origin, const Vec3& center,
                            float radius, int samples, uint64_t seed, int* rays) {
    if (rays) *rays = 0;
    const SphereLightRays sampler(origin, center, radius, samples, seed);
    if (sampler.Inside()) return 1.0f;
    int visible = 0;
    // kRayBatch rays at a time: from one point into a narrow cone, coherent enough for a
    // packet (Accelerator::OccludedMany).
    Ray batch[kRayBatch];
    bool blocked[kRayBatch];
    for (int first = 0; first < samples; first += kRayBatch) {
        const int n = std::min(kRayBatch, samples - first);
        for (int k = 0; k < n; ++k) batch[k] = sampler.Get(first + k);
        accel.OccludedMany(batch, static_cast<size_t>(n), blocked);
        for (int k = 0; k < n; ++k) visible += !blocked[k];
    }
    if (rays) *rays = samples;
    return static_cast<float>(visible) / static_cast<float>(samples);
}

DiscRings::DiscRings(const Vec3& origin, const Vec3& center, float radius, int perRing, uint64_t seed)
    : origin_(origin), oc_(center - origin), radius_(radius), perRing_(std::clamp(perRing, 1, kMaxPerRing)) {
    const float d2 = LengthSquared(oc_);
    inside_ = d2 <= radius * radius;  // inside the light: all of it is visible
    if (inside_) return;
    CoordinateSystem(oc_ / std::sqrt(d2), &e1_, &e2_);
    // The rings' directions by rotation from one sine and cosine per point: point k of the
    // outer ring at turn + k·step, of the inner ring at turn + (k + ½)·step. The half
    // step's cosine and sine per ring size are computed once (the same floats).
    struct HalfSteps {
        float cs[kMaxPerRing + 1], sn[kMaxPerRing + 1];
        HalfSteps() {
            for (int n = 1; n <= kMaxPerRing; ++n) {
                const float step = 2 * Pi / static_cast<float>(n);
                cs[n] = std::cos(0.5f * step);
                sn[n] = std::sin(0.5f * step);
            }
        }
    };
    static const HalfSteps halfSteps;
    const float step = 2 * Pi / static_cast<float>(perRing_);
    const float turn = UnitFloat(seed >> 40) * step;
    cs_ = halfSteps.cs[perRing_];
    sn_ = halfSteps.sn[perRing_];
    c0_ = std::cos(turn);
    s0_ = std::sin(turn);
}

void DiscRings::Rays(float ringRadius, bool inner, Ray* out) const {
    float c = c0_, s = s0_;
    auto advance = [&] {  // the angle += step / 2
        const float c2 = c * cs_ - s * sn_;
        s = s * cs_ + c * sn_;
        c = c2;
    };
    if (inner) advance();
    const float r = ringRadius * radius_;
    for (int k = 0; k < perRing_; ++k, advance(), advance()) {
        const Vec3 to = oc_ + e1_ * (r * c) + e2_ * (r * s);
        // Like LightVisible, stop just short of the light itself.
        out[k] = Ray{origin_, to, 0.0f, 1.0f - 1e-5f};
    }
}

float DiscLightVisibility(const Accelerator& accel, const Vec3& origin, const Vec3& center, float radius,
                          int perRing, uint64_t seed, int* rays) {
    if (rays) *rays = 0;
    const DiscRings rings(origin, center, radius, perRing, seed);
    if (rings.Inside()) return 1.0f;
    // One ring's rays at once: from one point to a small disc, the coherent rays a packet
    // traces best (Accelerator::OccludedMany). The outer ring first (radius sqrt(3/4): the
    // middle of the outer half of the area), then the inner (sqrt(1/4)), each point the
    // centre of an equal share of the disc.
    const int n = rings.PerRing();
    Ray batch[DiscRings::kMaxPerRing];
    bool blocked[DiscRings::kMaxPerRing];
    auto visible = [&] {
        accel.OccludedMany(batch, static_cast<size_t>(n), blocked);
        int v = 0;
        for (int k = 0; k < n; ++k) v += !blocked[k];
        return v;
    };
    rings.OuterRays(batch);
    const int outer = visible();
    if (rings.OuterDecides(outer)) {
        if (rays) *rays = n;
        return rings.Value(outer, 0);
    }
    rings.InnerRays(batch);
    const int inner = visible();
    if (rays) *rays = 2 * n;
    return rings.Value(outer, inner);
}

namespace {

/// "area": the Monte Carlo soft-shadow reference.
class AreaLightShadows final : public ShadowMethod {
  public:
    AreaLightShadows(const Scene& scene, const Accelerator& accel, const AreaLightOptions& options,
                     std::vector<float> radii, std::string_view name)
        : scene_(scene), accel_(accel), options_(options), radii_(std::move(radii)), name_(name) {}
    std::string_view Name() const override { return name_; }

    void Visibility(const ShadingPoint& sp, LightIndices lights, float* vis, RenderCounters& counters) const override {
        for (size_t k = 0; k < lights.size(); ++k) {
            const uint32_t i = lights[k];
            const Vec3& center = scene_.lights[i].position;
            if (radii_[i] == 0) {
                // A point light: exactly the shadow ray of "rt", so R = 0 equals RT bit for bit.
                ++counters.shadowRays;
                vis[k] = LightVisible(accel_, sp.origin, center) ? 1.0f : 0.0f;
                continue;
            }
            int rays = 0;
            vis[k] = SphereLightVisibility(accel_, sp.origin, center, radii_[i], options_.samples,
                                           AreaLightSeed(sp, i, options_.stream), &rays);
            counters.shadowRays += static_cast<uint64_t>(rays);
        }
    }

    // One radius when every light has it (the override), else the list in light order.
    ShadowFigures Figures() const override {
        const bool same = std::all_of(radii_.begin(), radii_.end(), [&](float r) { return r == radii_.front(); });
        const size_t points = static_cast<size_t>(std::count(radii_.begin(), radii_.end(), 0.0f));
        std::string radii;
        for (size_t i = 0; i < (same ? std::min<size_t>(radii_.size(), 1) : radii_.size()); ++i)
            radii += (i ? ", " : "") + StringPrintf("%.3g", static_cast<double>(radii_[i]));
        const std::string samples = points == radii_.size() ? "1"
                                    : points == 0
                                        ? std::to_string(options_.samples)
                                        : StringPrintf("%d (1 for the lights of radius 0)", options_.samples);
        return {{same ? "light radius" : "light radii", radii}, {"samples per light", samples}};
    }

  private:
    const Scene& scene_;
    const Accelerator& accel_;
    const AreaLightOptions options_;
    const std::vector<float> radii_;  ///< per light, from LightRadii
    const std::string_view name_;
};

}  // namespace

std::unique_ptr<ShadowMethod> CreateAreaLightShadows(const Scene& scene, const Accelerator& accel,
                                                     const AreaLightOptions& options, std::vector<float> radii,
                                                     std::string_view name) {
    ValidateAreaLightOptions(options);
    if (radii.size() != scene.lights.size())
        ThrowError("area lights: %zu radii for %zu lights", radii.size(), scene.lights.size());
    for (size_t i = 0; i < radii.size(); ++i)
        if (!(std::isfinite(radii[i]) && radii[i] >= 0))
            ThrowError("%s: light %zu: radius %g: must be a finite number >= 0", scene.name.c_str(), i,
                       static_cast<double>(radii[i]));
    return std::make_unique<AreaLightShadows>(scene, accel, options, std::move(radii), name);
}

}  // namespace lm
