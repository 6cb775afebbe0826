#include "lightmesh/render/render_job.h"

#include <chrono>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

namespace {

/// A scene too small for single-precision ray queries (issue 45: a box at 1e-17 scale,
/// which loads since degeneracy is judged per triangle, rendered without its shadows): the
/// products of three lengths in a ray/triangle test underflow below float's 1.2e-38.
/// Measured on a box with its ground, camera and light: Embree's images are exact down to
/// a span of 3e-8 and wrong at 2e-9; the grid's and brute force's exact to 2e-13, wrong at
/// 2e-14. The limits leave a factor of 30 to 50.
void CheckSceneSpan(const Scene& scene, const std::string& accel) {
    Bounds3 b = scene.mesh.Bounds();
    for (const PointLight& l : scene.lights) b.Extend(l.position);
    b.Extend(scene.camera.position);
    const float span = MaxComponent(b.Diagonal());
    const float least = accel == "embree" ? 1e-6f : 1e-11f;
    if (span < least)
        ThrowErrorAt({scene.name},
                     "the scene (meshes, ground, camera and lights) spans %g, less than the %g that single-precision "
                     "ray queries resolve with --accel %s (scale the model up%s)",
                     double(span), double(least), accel.c_str(),
                     accel == "embree" && span >= 1e-11f ? ", or use --accel grid" : "");
}

}  // namespace

RenderJob::RenderJob(const Scene& scene, const RenderOptions& options, const Accelerator* accel)
    : options_(options), accel_(accel) {
    CheckSceneSpan(scene, accel ? std::string(accel->Name()) : options.accel);
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
    if (options_.shadows == "denoised")
        denoiser_ = std::make_unique<ShadowDenoiser>(scene, *accel_, *renderer_, options_, LightRadii(scene, options_));
    if (options_.shadows == "soft")
        frame_ = std::make_unique<SoftFrame>(scene, *accel_, *renderer_, options_, LightRadii(scene, options_),
                                             SoftFrameSamples(options_.soft));
}

}  // namespace lm
