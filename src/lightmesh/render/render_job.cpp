#include "lightmesh/render/render_job.h"

#include <algorithm>
#include <chrono>

#include "lightmesh/geometry/instances.h"
#include "lightmesh/io/tonemap.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/shadow/area_light.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

namespace lm {

namespace {

/// A scene too small for single-precision ray queries (a box at 1e-17 scale, which loads
/// since degeneracy is judged per triangle, would render without its shadows): the
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

void CheckRenderOptions(const Scene& scene, const RenderOptions& options, const std::vector<std::string>& given) {
    auto isGiven = [&](const char* key) { return std::find(given.begin(), given.end(), key) != given.end(); };
    // Flags the chosen method or back-end does not use get a warning each, as pbrt reports
    // unused parameters (which knob each method uses is the settings table's). A scene
    // file's "render" values stay silent: a file may set up several methods.
    for (const RenderSetting& setting : RenderSettings()) {
        if (!isGiven(setting.key) || !setting.usedWith) continue;
        const std::string warning = UnusedSettingWarning(
            setting.key, std::string(setting.usedWith) == "accel" ? options.accel : options.shadows);
        if (!warning.empty()) LogWarning(warning);
    }
    NamingOrigins(options, [&] {
        if (options.shadows == "lmm") ParseLightMeshVariant(options.lightMesh.variant);
        if (options.shadows == "area" || options.shadows == "denoised" || isGiven("light_radius") || isGiven("samples"))
            ValidateAreaLightOptions(options.areaLight);
    });
    if (isGiven("thin_check") && options.shadows == "lmm" && !(options.areaLight.radius.value_or(0.0f) > 0))
        LogWarning("--thin-check is used only with a light radius (--light-radius > 0); ignored");
    if (options.shadows == "area" || options.shadows == "denoised") {
        // Only when no light has a size left: the lights' own radii, unless overridden.
        const std::vector<float> radii = LightRadii(scene, options);
        if (std::all_of(radii.begin(), radii.end(), [](float r) { return r == 0; }))
            LogWarning(options.areaLight.radius
                           ? "--shadows " + options.shadows +
                                 " with light radius 0: point lights, the same image as --shadows rt "
                                 "(set --light-radius > 0)"
                           : "--shadows " + options.shadows +
                                 " with every light's radius 0: point lights, the same image as "
                                 "--shadows rt (give the lights a \"radius\" or set --light-radius)");
    }
}

void PrepareSceneForRender(Scene* scene, const RenderOptions& options, const std::string& sceneName) {
    const uint64_t imageBytes = static_cast<uint64_t>(options.width) * options.height * sizeof(Color);
    const uint64_t physical = PhysicalMemoryBytes();
    if (physical && imageBytes > physical / 2)
        ThrowError("image %dx%d would need %s, more than half of this machine's %s", options.width, options.height,
                   FormatBytes(imageBytes).c_str(), FormatBytes(physical).c_str());

    // The light mesh, brute force and the grid read triangles as one array: instances are
    // flattened for them, refused first past the budget, naming the scene and the option.
    const std::string who = Printable(sceneName) + ": ";
    if (options.accel != "embree") CheckFlatteningFits(scene->mesh, who + "--accel " + options.accel + ": ");
    if (options.shadows == "lmm" && scene->mesh.instances) {
        const size_t instances = scene->mesh.instances->Instances().size();
        FlattenInstances(&scene->mesh, who + "--shadows lmm: ");
        const TriangleMesh& m = scene->mesh;
        LogInfo(StringPrintf("--shadows lmm: %s instances flattened into %s triangles (%s)",
                             FormatCount(instances).c_str(), FormatCount(m.TriangleCount()).c_str(),
                             FormatBytes(m.positions.size() * sizeof(Vec3) + m.normals.size() * sizeof(Vec3) +
                                         m.uvs.size() * sizeof(TexCoord) + m.triangles.size() * 16)
                                 .c_str()));
    }
}

RenderJob::RenderJob(const Scene& scene, const RenderOptions& options, const Accelerator* accel)
    : options_(options), accel_(accel), lights_(scene.lights.size()) {
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

StatsLines RenderJob::CounterLines(const RenderCounters& c) const {
    StatsLines lines = frame_ ? frame_->CounterLines(c) : shadows_->CounterLines(c);
    if (const LightCuts* cuts = renderer_->Cuts()) {
        const double points = static_cast<double>(std::max<uint64_t>(c.shadingPoints, 1));
        lines.insert(lines.begin(),
                     {"light cut", StringPrintf("error bound %g %%, %zu lights in a hierarchy of %zu nodes (%s); per "
                                                "shading point %.1f entries on average, %llu at most",
                                                100.0 * cuts->Error(), lights_, cuts->NodeCount(),
                                                FormatBytes(cuts->Bytes()).c_str(), static_cast<double>(c.cutEntries) / points,
                                                static_cast<unsigned long long>(c.cutLargest))});
    }
    return lines;
}

RenderResult RenderJob::Render(ProgressReporter* progress, VisibilityImage* visibility) const {
    if (visibility && (visibility->width != options_.width || visibility->height != options_.height ||
                       visibility->lights != lights_))
        ThrowError("visibility image %dx%d of %zu lights for a %dx%d render of %zu lights", visibility->width,
                   visibility->height, visibility->lights, options_.width, options_.height, lights_);
    const BandRenderer* bands = Bands();
    RenderResult result = bands ? bands->Render(options_.width, options_.height, progress, visibility)
                                : renderer_->Render(progress, visibility);
    ApplyExposure(&result.image, options_.exposure);
    return result;
}

}  // namespace lm
