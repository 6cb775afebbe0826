// render_job.h -- one render from a scene and its settings: the ray-query back-end, the
// shadow method and the Whitted renderer wired together, with the time each took. The
// CLI (one process or MPI ranks), `bench`, the fuzz targets and the real-scene tests all
// render through it.
#pragma once

#include <memory>

#include "lightmesh/render/shadow_denoiser.h"
#include "lightmesh/render/whitted.h"

namespace lm {

class RenderJob {
  public:
    /// Builds the back-end options.accel (or uses `accel`: the bench shares one per scene;
    /// it must outlive the job), the shadow method options.shadows and the renderer for
    /// `scene`, which must outlive the job. Throws Error for bad settings.
    RenderJob(const Scene& scene, const RenderOptions& options, const Accelerator* accel = nullptr);

    /// Renders the whole image (WhittedRenderer::Render; with "--shadows denoised",
    /// ShadowDenoiser::Render).
    RenderResult Render(ProgressReporter* progress = nullptr) const {
        return denoiser_ ? denoiser_->Render(progress) : renderer_->Render(progress);
    }

    const Accelerator& Accel() const { return *accel_; }
    const ShadowMethod& Shadows() const { return *shadows_; }
    const WhittedRenderer& Renderer() const { return *renderer_; }
    /// The shadow denoiser of "--shadows denoised" (which renders by bands of rows, not by
    /// the renderer's tiles), else null.
    const ShadowDenoiser* Denoiser() const { return denoiser_.get(); }
    const RenderOptions& Options() const { return options_; }
    /// Seconds spent building the back-end (0 when it was given) and the shadow method.
    double BuildSeconds() const { return buildSeconds_; }
    double ShadowSetupSeconds() const { return shadowSetupSeconds_; }

  private:
    const RenderOptions options_;
    std::unique_ptr<Accelerator> ownAccel_;
    const Accelerator* accel_ = nullptr;
    std::unique_ptr<ShadowMethod> shadows_;
    std::unique_ptr<WhittedRenderer> renderer_;
    std::unique_ptr<ShadowDenoiser> denoiser_;
    double buildSeconds_ = 0, shadowSetupSeconds_ = 0;
};

}  // namespace lm
