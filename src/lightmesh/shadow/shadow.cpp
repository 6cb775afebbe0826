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

void LightsVisible(const Accelerator& accel, const Vec3& origin, std::span<const PointLight> lights, LightIndices ids,
                   float* vis) {
    constexpr size_t kChunk = 16;  // as above
    Ray rays[kChunk];
    bool blocked[kChunk];
    for (size_t first = 0; first < ids.size(); first += kChunk) {
        const size_t n = std::min(kChunk, ids.size() - first);
        for (size_t k = 0; k < n; ++k) rays[k] = LightSegment(origin, lights[ids[first + k]].position);
        accel.OccludedMany(rays, n, blocked);
        for (size_t k = 0; k < n; ++k) vis[first + k] = blocked[k] ? 0.0f : 1.0f;
    }
}

uint64_t LightsVisibleMany(const Accelerator& accel, const ShadingPoint* sps, size_t count,
                           std::span<const PointLight> lights, const uint64_t* masks, uint64_t* visible) {
    constexpr size_t kChunk = 64;
    Ray rays[kChunk];
    size_t which[kChunk];
    bool blocked[kChunk];
    uint64_t traced = 0;
    std::fill(visible, visible + count, uint64_t(0));
    uint64_t any = 0;  // the lights some point needs
    for (size_t i = 0; i < count; ++i) any |= masks[i];
    if (lights.size() < 64) any &= (uint64_t(1) << lights.size()) - 1;
    for (; any; any &= any - 1) {
        const size_t l = static_cast<size_t>(__builtin_ctzll(any));
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

void ShadowMethod::VisibilityMany(const ShadingPoint* sps, const LightIndices* lights, float* const* vis, size_t count,
                                  RenderCounters& counters) const {
    for (size_t i = 0; i < count; ++i) Visibility(sps[i], lights[i], vis[i], counters);
}

namespace {

/// "none": every light is visible everywhere (the floor that shadow work sits on).
class NoShadows final : public ShadowMethod {
  public:
    std::string_view Name() const override { return "none"; }
    void Visibility(const ShadingPoint&, LightIndices lights, float* vis, RenderCounters&) const override {
        std::fill(vis, vis + lights.size(), 1.0f);
    }
};

/// "rt": Whitted's hard shadows, one shadow ray per light (formula (1)), to the lights the
/// point needs only.
class HardShadows final : public ShadowMethod {
  public:
    HardShadows(const Scene& scene, const Accelerator& accel) : scene_(scene), accel_(accel) {}
    std::string_view Name() const override { return "rt"; }
    void Visibility(const ShadingPoint& sp, LightIndices lights, float* vis, RenderCounters& counters) const override {
        counters.shadowRays += lights.size();
        LightsVisible(accel_, sp.origin, scene_.lights, lights, vis);
    }
    // Light by light, the points' shadow rays to it together (LightsVisibleMany): rays
    // from neighbouring points to one light are coherent, which a back-end traces as a
    // packet (Embree's rtcOccluded8, the grid's coherent traversal). The lights go 64 at a
    // time (a mask per point), only the runs of 64 that some point's list reaches: each
    // point's list is walked once, whatever the scene's count.
    void VisibilityMany(const ShadingPoint* sps, const LightIndices* lights, float* const* vis, size_t count,
                        RenderCounters& counters) const override {
        constexpr size_t kChunk = 64;  // points at a time, for the masks on the stack
        const std::span<const PointLight> all(scene_.lights);
        uint64_t masks[kChunk], visible[kChunk];
        size_t at[kChunk], start[kChunk];  // each point's place in its list: now, at the run's start
        for (size_t first = 0; first < count; first += kChunk) {
            const size_t n = std::min(kChunk, count - first);
            const LightIndices* ids = lights + first;
            std::fill(at, at + n, size_t(0));
            for (;;) {
                uint32_t run = UINT32_MAX;  // the lowest run of 64 lights a point still needs
                for (size_t i = 0; i < n; ++i)
                    if (at[i] < ids[i].size()) run = std::min(run, ids[i][at[i]] >> 6);
                if (run == UINT32_MAX) break;
                for (size_t i = 0; i < n; ++i) {
                    start[i] = at[i];
                    masks[i] = 0;
                    for (; at[i] < ids[i].size() && ids[i][at[i]] >> 6 == run; ++at[i])
                        masks[i] |= uint64_t(1) << (ids[i][at[i]] & 63);
                }
                const size_t l0 = size_t(run) << 6;
                counters.shadowRays += LightsVisibleMany(accel_, sps + first, n, all.subspan(l0, std::min<size_t>(64, all.size() - l0)),
                                                         masks, visible);
                for (size_t i = 0; i < n; ++i)
                    for (size_t k = start[i]; k < at[i]; ++k)
                        vis[first + i][k] = (visible[i] >> (ids[i][k] & 63)) & 1 ? 1.0f : 0.0f;
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

std::vector<std::string> ShadowMethodNames() { return {"soft", "exact", "none", "rt", "lmm", "area", "denoised"}; }

std::vector<float> LightRadii(const Scene& scene, const RenderOptions& options) {
    std::vector<float> radii;
    radii.reserve(scene.lights.size());
    for (const PointLight& light : scene.lights) {
        // A sun's radius is its far sphere's, set by its angle: an override in scene units
        // would mean nothing there, except 0, a point (its hard shadow).
        const bool keep = light.kind == LightKind::Sun && options.areaLight.radius && *options.areaLight.radius > 0;
        radii.push_back(keep ? light.radius : options.areaLight.radius.value_or(light.radius));
    }
    return radii;
}

std::unique_ptr<ShadowMethod> CreateShadowMethod(std::string_view name, const Scene& scene,
                                                 const Accelerator& accel,
                                                 const RenderOptions& options) {
    if (name == "none") return std::make_unique<NoShadows>();
    if (name == "rt") return std::make_unique<HardShadows>(scene, accel);
    if (name == "soft") {
        // The default renders by frames (render/soft_frame.h, RenderJob); this per-point
        // method answers the hits it cannot see from the camera (mirrors): area's N rays.
        AreaLightOptions area = options.areaLight;
        area.samples = SoftFrameSamples(options.soft);
        return CreateAreaLightShadows(scene, accel, area, LightRadii(scene, options), "soft");
    }
    if (name == "exact") {
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
    ThrowSettingError("shadows", "unknown shadow method \"%.*s\" (choose soft, exact, none, rt, lmm, area or denoised)", static_cast<int>(name.size()),
               name.data());
}

}  // namespace lm
