#include "lightmesh/render/render_job.h"

#include <chrono>

#include "lightmesh/util/system.h"

namespace lm {

RenderJob::RenderJob(const Scene& scene, const RenderOptions& options, const Accelerator* accel)
    : options_(options), accel_(accel) {
    // The factories read their own knobs; an error in one names where its value came from.
    if (!accel_) {
        const auto t0 = std::chrono::steady_clock::now();
        ownAccel_ = NamingOrigins(options_, [&] { return CreateAccelerator(options_.accel, scene.mesh, options_.accelOptions); });
        buildSeconds_ = SecondsSince(t0);
        accel_ = ownAccel_.get();
    }
    const auto t1 = std::chrono::steady_clock::now();
    shadows_ = NamingOrigins(options_, [&] { return CreateShadowMethod(options_.shadows, scene, *accel_, options_); });
    shadowSetupSeconds_ = SecondsSince(t1);
    renderer_ = std::make_unique<WhittedRenderer>(scene, *accel_, *shadows_, options_);
}

}  // namespace lm
