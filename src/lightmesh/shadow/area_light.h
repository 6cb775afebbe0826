// area_light.h -- the soft-shadow reference: every point light becomes a sphere, and each
// shading point traces N stratified shadow rays per light (the paper's "naive" soft
// shadows, §1.2).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "lightmesh/shadow/disc_pattern.h"
#include "lightmesh/shadow/shadow.h"

namespace lm {

/// Throws Error unless the radius override (when set) is finite and >= 0 and samples is in
/// 1 .. 4096.
void ValidateAreaLightOptions(const AreaLightOptions& options);

/// The seed of the sample sequence of one (shading point, light) pair: a hash of the bits
/// of sp.p, of sp.prim, of the light's index and of `stream`. So the estimate depends only
/// on the point, never on the thread, the tile order or the pixel that found the point.
/// Stream 0 is every render's; another stream draws rotations independent of it
/// (AreaLightOptions::stream).
uint64_t AreaLightSeed(const ShadingPoint& sp, uint32_t light, uint32_t stream = 0);

/// The fraction of a spherical light (centre `center`, radius `radius` > 0) visible from
/// `origin`, estimated with `samples` shadow rays: directions stratified over the cone
/// the sphere subtends (uniform in solid angle), randomised by `seed`, each ray ending
/// on the near side of the sphere. Returns 1 without tracing when `origin` is inside the
/// sphere (d <= radius): a point inside the light sees all of it. `*rays` (if given) gets
/// the number of rays traced.
float SphereLightVisibility(const Accelerator& accel, const Vec3& origin, const Vec3& center,
                            float radius, int samples, uint64_t seed, int* rays = nullptr);

/// The shadow rays SphereLightVisibility traces, one by one, for a caller that needs more
/// than whether they are blocked (the shadow denoiser reads where they are blocked): ray
/// `index` of `samples` goes from `origin` to the near side of the sphere; each ray's
/// direction ends at t = 1 − 1e-5 (ray.d spans the segment).
class SphereLightRays {
  public:
    SphereLightRays(const Vec3& origin, const Vec3& center, float radius, int samples, uint64_t seed);
    /// The origin lies inside the light: V = 1 without rays.
    bool Inside() const { return cone_.Inside(); }
    Ray Get(int index) const;

  private:
    SphereCone cone_;
    float shift0_ = 0, shift1_ = 0;
    int samples_ = 1;
};

/// A cheaper estimate of the same fraction, for the light mesh's narrow penumbrae: the
/// light as the disc of radius `radius` it shows `origin` (centred on `center`, facing it;
/// for radius << distance the sphere's silhouette), sampled at the centres of 2·perRing
/// equal shares of its area: perRing points on a ring at 0.866·radius, then perRing on a
/// ring at 0.5·radius between them, the pattern turned by an angle from `seed`. The outer
/// ring is traced first; if its rays all agree the light is taken as wholly visible or
/// hidden (what they can miss is a sliver of the rim, about 11 % of the disc for 4 per
/// ring), otherwise the inner ring too and all are averaged. perRing is 1 .. 32.
float DiscLightVisibility(const Accelerator& accel, const Vec3& origin, const Vec3& center, float radius,
                          int perRing, uint64_t seed, int* rays = nullptr);

/// DiscLightVisibility in steps, for a caller that traces the rings of many points together
/// (each ray's answer from a back-end does not depend on the rays traced with it): the
/// rays of the outer ring, whether its count decides, the inner ring's rays, the
/// estimate. DiscLightVisibility itself is these steps.
class DiscRings {
  public:
    static constexpr int kMaxPerRing = 32;
    DiscRings(const Vec3& origin, const Vec3& center, float radius, int perRing, uint64_t seed);
    /// The origin lies inside the light: V = 1 without rays.
    bool Inside() const { return inside_; }
    int PerRing() const { return perRing_; }
    /// The rings' perRing rays each, to out[0 .. perRing-1].
    void OuterRays(Ray* out) const { Rays(0.8660254f, false, out); }
    void InnerRays(Ray* out) const { Rays(0.5f, true, out); }
    /// Whether the outer ring's count of visible rays is the answer (all or none visible).
    bool OuterDecides(int outerVisible) const { return outerVisible == 0 || outerVisible == perRing_; }
    /// The estimate from the visible rays of the outer ring and (unless it decided) the inner.
    float Value(int outerVisible, int innerVisible) const {
        if (OuterDecides(outerVisible)) return outerVisible == 0 ? 0.0f : 1.0f;
        return static_cast<float>(outerVisible + innerVisible) / static_cast<float>(2 * perRing_);
    }

  private:
    void Rays(float ringRadius, bool inner, Ray* out) const;
    Vec3 origin_, oc_, e1_, e2_;
    float radius_ = 0, c0_ = 1, s0_ = 0, cs_ = 1, sn_ = 0;
    int perRing_ = 1;
    bool inside_ = false;
};

/// Direction `index` of `samples` in the cone around the unit vector `axis` whose
/// half-angle θmax has 1 - cos θmax = `oneMinusCosMax` (in [0, 1]): uniform in solid
/// angle and stratified, shifted by (`shift0`, `shift1`) in [0, 1)² (Cranley–Patterson
/// rotation). Exposed for tests.
Vec3 SampleConeStratified(const Vec3& axis, float oneMinusCosMax, int index, int samples,
                          float shift0, float shift1);

/// "area": soft shadows from spherical lights by Monte Carlo, light i a sphere of radius
/// radii[i] (LightRadii: the lights' own radii or the override). For a light of radius 0 it
/// traces exactly the shadow ray of "rt", so with every radius 0 the images are
/// bit-identical. Throws Error for bad options (ValidateAreaLightOptions) or radii (not one
/// per light, negative or not finite). `name` is its Name(): "denoised" when the camera
/// hits' visibility is filtered afterwards (render/shadow_denoiser.h), a string literal.
std::unique_ptr<ShadowMethod> CreateAreaLightShadows(const Scene& scene, const Accelerator& accel,
                                                     const AreaLightOptions& options, std::vector<float> radii,
                                                     std::string_view name = "area");

}  // namespace lm
