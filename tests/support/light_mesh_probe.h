// light_mesh_probe.h -- a light mesh over a scene, asked for the visibility of single
// shading points: the light mesh's and the penumbra mode's unit tests.
#pragma once

#include <algorithm>
#include <memory>
#include <string>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/shadow/light_mesh.h"
#include "support/light_indices.h"

namespace lm::testing {

struct LightMeshProbe {
    std::unique_ptr<Accelerator> accel;
    std::unique_ptr<LightMeshShadows> lmm;
    std::vector<uint32_t> all;  // every light of the scene
    LightMeshProbe(const Scene& s, const LightMeshOptions& options, const std::string& accelName = "grid")
        : all(AllLights(s.lights.size())) {
        accel = CreateAccelerator(accelName, s.mesh);
        lmm = CreateLightMeshShadows(s, *accel, options);
    }
    /// V of `light` at sp, every light needed; the work is added to *counters if given.
    float Vis(const ShadingPoint& sp, int light = 0, RenderCounters* counters = nullptr) const {
        std::vector<float> vis(all.size());
        RenderCounters c;
        lmm->Visibility(sp, all, vis.data(), counters ? *counters : c);
        return vis[static_cast<size_t>(light)];
    }
};

/// LightMeshOptions with the knobs the tests vary.
inline LightMeshOptions LightMeshSettings(int cc, float ki, const std::string& variant = "", float lightRadius = 0) {
    LightMeshOptions o;
    o.cc = cc;
    o.ki = ki;
    o.variant = variant;
    o.lightRadius = lightRadius;
    return o;
}

}  // namespace lm::testing
