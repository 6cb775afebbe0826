// render_job.h -- one render from a scene and its settings: the ray-query back-end, the
// shadow method and the Whitted renderer wired together, with the time each took. The
// CLI (one process or MPI ranks), `bench`, the fuzz targets and the real-scene tests all
// render through it.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "lightmesh/render/shadow_denoiser.h"
#include "lightmesh/render/soft_frame.h"
#include "lightmesh/render/whitted.h"

namespace lm {

/// What every front end (the CLI, the Python module) does once a render's options are
/// merged, before anything else is checked: a warning for each knob in `given` (scene-file
/// keys the caller set explicitly, worded with its flag) that the chosen method or back-end
/// does not use, the light-mesh variant and the area-light options checked (an error names
/// where the value came from, RenderOptions::origins), and warnings for settings that
/// change nothing (--thin-check without a light radius, area shadows of point lights).
void CheckRenderOptions(const Scene& scene, const RenderOptions& options, const std::vector<std::string>& given);

/// The last step before RenderJob: refuses an image that would need more than half of the
/// machine's memory, and, for the back-ends and the shadow method that read one triangle
/// array, flattens the scene's instances (refused past the memory budget, naming
/// `sceneName` and the option).
void PrepareSceneForRender(Scene* scene, const RenderOptions& options, const std::string& sceneName);

class RenderJob {
  public:
    /// Builds the back-end options.accel (or uses `accel`: the bench shares one per scene;
    /// it must outlive the job), the shadow method options.shadows and the renderer for
    /// `scene`, which must outlive the job. Throws Error for bad settings.
    RenderJob(const Scene& scene, const RenderOptions& options, const Accelerator* accel = nullptr);

    /// Renders the whole image (WhittedRenderer::Render; with "--shadows denoised",
    /// ShadowDenoiser::Render), times 2^exposure (RenderOptions::exposure). With `visibility` (null: none, no work), the per-light
    /// visibility each pixel's camera hits were shaded with goes there too: the render's size
    /// and light count (MakeVisibility), filled by whichever method renders.
    RenderResult Render(ProgressReporter* progress = nullptr, VisibilityImage* visibility = nullptr) const;
    /// An empty visibility image for this job's renders.
    VisibilityImage MakeVisibility() const { return VisibilityImage(options_.width, options_.height, lights_); }

    const Accelerator& Accel() const { return *accel_; }
    const ShadowMethod& Shadows() const { return *shadows_; }
    /// The shadow work's counts for --stats: the frame's (the soft default) or the method's.
    /// With a light cut, first its line: the bound, the hierarchy and the cuts' sizes.
    StatsLines CounterLines(const RenderCounters& counters) const;
    const WhittedRenderer& Renderer() const { return *renderer_; }
    /// The shadow denoiser of "--shadows denoised", else null.
    const ShadowDenoiser* Denoiser() const { return denoiser_.get(); }
    /// What renders the image by bands of rows, not by the renderer's tiles: the soft
    /// default's frame or the denoiser; null for the per-tile methods.
    const BandRenderer* Bands() const {
        if (frame_) return frame_.get();
        return denoiser_.get();
    }
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
    std::unique_ptr<SoftFrame> frame_;
    size_t lights_ = 0;
    double buildSeconds_ = 0, shadowSetupSeconds_ = 0;
};

}  // namespace lm
