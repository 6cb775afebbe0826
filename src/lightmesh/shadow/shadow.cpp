#include "lightmesh/shadow/shadow.h"

#include <algorithm>
#include <cmath>

#include "lightmesh/settings/render_settings.h"
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/shadow/soft_shadows.h"
#include "lightmesh/util/error.h"

namespace lm {

bool LightVisible(const Accelerator& accel, const Vec3& origin, const Vec3& light) {
    return !accel.Occluded(LightSegment(origin, light));
}

uint64_t LightsVisible(const Accelerator& accel, const Vec3& origin, std::span<const PointLight> lights,
                       uint64_t mask) {
    // 16 rays at a time, Embree's widest packet: a Ray is initialised where it is
    // declared, and this runs once per shading point (and per light-mesh node with 16
    // lights or more), so the buffer stays small.
    constexpr size_t kChunk = 16;
    Ray rays[kChunk];
    int which[kChunk];
    bool blocked[kChunk];
    uint64_t visible = 0;
    size_t n = 0;
    auto trace = [&] {
        accel.OccludedMany(rays, n, blocked);
        for (size_t k = 0; k < n; ++k)
            if (!blocked[k]) visible |= uint64_t(1) << which[k];
        n = 0;
    };
    for (uint64_t m = mask; m; m &= m - 1) {
        const int l = __builtin_ctzll(m);
        if (static_cast<size_t>(l) >= lights.size()) break;
        rays[n] = LightSegment(origin, lights[static_cast<size_t>(l)].position);
        which[n] = l;
        if (++n == kChunk) trace();
    }
    if (n) trace();
    return visible;
}

uint64_t LightsVisibleMany(const Accelerator& accel, const ShadingPoint* sps, size_t count,
                           std::span<const PointLight> lights, const uint64_t* masks, uint64_t* visible) {
    constexpr size_t kChunk = 64;
    Ray rays[kChunk];
    size_t which[kChunk];
    bool blocked[kChunk];
    uint64_t traced = 0;
    std::fill(visible, visible + count, uint64_t(0));
    for (size_t l = 0; l < std::min<size_t>(lights.size(), 64); ++l) {
        size_t n = 0;
        auto trace = [&] {
            accel.OccludedMany(rays, n, blocked);
            for (size_t k = 0; k < n; ++k)
                if (!blocked[k]) visible[which[k]] |= uint64_t(1) << l;
            traced += n;
            n = 0;
        };
        for (size_t i = 0; i < count; ++i) {
            if (!((masks[i] >> l) & 1)) continue;
            rays[n] = LightSegment(sps[i].origin, lights[l].position);
            which[n] = i;
            if (++n == kChunk) trace();
        }
        if (n) trace();
    }
    return traced;
}

void ShadowMethod::VisibilityMany(const ShadingPoint* sps, size_t count, size_t lights, const bool* needed,
                                  float* vis, RenderCounters& counters) const {
    for (size_t i = 0; i < count; ++i) Visibility(sps[i], needed + i * lights, vis + i * lights, counters);
}

namespace {

/// "none": every light is visible everywhere (the floor that shadow work sits on).
class NoShadows final : public ShadowMethod {
  public:
    explicit NoShadows(size_t lights) : lights_(lights) {}
    std::string_view Name() const override { return "none"; }
    void Visibility(const ShadingPoint&, const bool*, float* vis, RenderCounters&) const override {
        for (size_t i = 0; i < lights_; ++i) vis[i] = 1.0f;
    }

  private:
    size_t lights_;
};

/// "rt": Whitted's hard shadows, one shadow ray per light (formula (1)). Any number of
/// lights: their rays go out 64 lights at a time (a mask each), in light order.
class HardShadows final : public ShadowMethod {
  public:
    HardShadows(const Scene& scene, const Accelerator& accel) : scene_(scene), accel_(accel) {}
    std::string_view Name() const override { return "rt"; }
    void Visibility(const ShadingPoint& sp, const bool* needed, float* vis,
                    RenderCounters& counters) const override {
        const size_t lights = scene_.lights.size();
        const std::span<const PointLight> all(scene_.lights);
        for (size_t first = 0; first < lights; first += 64) {
            const size_t n = std::min<size_t>(64, lights - first);
            uint64_t mask = 0;
            for (size_t i = 0; i < n; ++i)
                if (needed[first + i]) mask |= uint64_t(1) << i;
            if (!mask) continue;
            counters.shadowRays += static_cast<uint64_t>(__builtin_popcountll(mask));
            const uint64_t visible = LightsVisible(accel_, sp.origin, all.subspan(first, n), mask);
            for (size_t i = 0; i < n; ++i)
                if (needed[first + i]) vis[first + i] = (visible >> i) & 1 ? 1.0f : 0.0f;
        }
    }
    // Light by light, the points' shadow rays to it together (LightsVisibleMany): rays
    // from neighbouring points to one light are coherent, which a back-end traces as a
    // packet (Embree's rtcOccluded8, the grid's coherent traversal). 64 lights at a time.
    void VisibilityMany(const ShadingPoint* sps, size_t count, size_t lights, const bool* needed, float* vis,
                        RenderCounters& counters) const override {
        constexpr size_t kChunk = 64;  // points at a time, for the masks on the stack
        const std::span<const PointLight> all(scene_.lights);
        uint64_t masks[kChunk], visible[kChunk];
        for (size_t first = 0; first < count; first += kChunk) {
            const size_t n = std::min(kChunk, count - first);
            for (size_t l0 = 0; l0 < lights; l0 += 64) {
                const size_t nl = std::min<size_t>(64, lights - l0);
                uint64_t any = 0;
                for (size_t i = 0; i < n; ++i) {
                    masks[i] = 0;
                    const bool* need = needed + (first + i) * lights + l0;
                    for (size_t l = 0; l < nl; ++l)
                        if (need[l]) masks[i] |= uint64_t(1) << l;
                    any |= masks[i];
                }
                if (!any) continue;
                counters.shadowRays += LightsVisibleMany(accel_, sps + first, n, all.subspan(l0, nl), masks, visible);
                for (size_t i = 0; i < n; ++i) {
                    float* v = vis + (first + i) * lights + l0;
                    for (uint64_t m = masks[i]; m; m &= m - 1) {
                        const int l = __builtin_ctzll(m);
                        v[l] = (visible[i] >> l) & 1 ? 1.0f : 0.0f;
                    }
                }
            }
        }
    }

  private:
    const Scene& scene_;
    const Accelerator& accel_;
};

// The angle between neighbouring camera rays of the image (vertically; the pixels are square).
float CameraRayAngle(const Camera& camera, const RenderOptions& options) {
    const int rows = options.height * std::max(options.aa, 1);
    if (rows <= 0 || !(camera.fovY > 0 && camera.fovY < 180)) return 0.0f;
    return 2.0f * std::tan(camera.fovY * 0.5f * Pi / 180.0f) / static_cast<float>(rows);
}

}  // namespace

std::vector<std::string> ShadowMethodNames() { return {"soft", "none", "rt", "lmm", "area", "denoised"}; }

std::vector<float> LightRadii(const Scene& scene, const RenderOptions& options) {
    std::vector<float> radii;
    radii.reserve(scene.lights.size());
    for (const PointLight& light : scene.lights) radii.push_back(options.areaLight.radius.value_or(light.radius));
    return radii;
}

std::unique_ptr<ShadowMethod> CreateShadowMethod(std::string_view name, const Scene& scene,
                                                 const Accelerator& accel,
                                                 const RenderOptions& options) {
    if (name == "none") return std::make_unique<NoShadows>(scene.lights.size());
    if (name == "rt") return std::make_unique<HardShadows>(scene, accel);
    if (name == "soft") {
        SoftShadowOptions soft = options.soft;
        soft.radii = LightRadii(scene, options);
        return CreateSoftShadows(scene, accel, soft);
    }
    if (name == "lmm") {
        // One light size for the reference and the light mesh's penumbrae.
        LightMeshOptions lmm = options.lightMesh;
        lmm.lightRadius = options.areaLight.radius.value_or(0.0f);  // the override only, not the lights' own
        lmm.rayAngle = CameraRayAngle(scene.camera, options);
        return CreateLightMeshShadows(scene, accel, lmm);
    }
    // "denoised": area's rays per point; RenderJob filters the camera hits' visibility
    // (render/shadow_denoiser.h), the mirrors keep these.
    if (name == "area") return CreateAreaLightShadows(scene, accel, options.areaLight, LightRadii(scene, options));
    if (name == "denoised")
        return CreateAreaLightShadows(scene, accel, options.areaLight, LightRadii(scene, options), "denoised");
    ThrowSettingError("shadows", "unknown shadow method \"%.*s\" (choose soft, none, rt, lmm, area or denoised)", static_cast<int>(name.size()),
               name.data());
}

}  // namespace lm
