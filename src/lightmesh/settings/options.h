// options.h -- everything that controls a render, from the scene file and the CLI.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lightmesh/settings/accel_options.h"
#include "lightmesh/settings/render_settings.h"

namespace lm {

/// Settings of the light mesh method (paper §2–4).
struct LightMeshOptions {
    /// Cells across the longest side of the scene's box (the paper's CC: 100, 200, 400).
    int cc = 100;
    /// Interpolation radius in mesh steps, r = kI·h (the paper's kI: 1.1 … 3).
    float ki = 2.0f;
    /// Variant of the paper's tables: "grid", "templates"(Ш), "reduced"(У), "none"(Нет),
    /// "inside"(СТ), "object"(ОТ). Filled in by the light-mesh module.
    std::string variant;
    /// Template sub-steps per cell side (paper §3.1); 0 means the documented default.
    int ns = 0;
    /// Template cache folder; empty means the XDG cache.
    std::string templateDir;
    /// Cell summaries (ours, not in the paper; exact: same images, less work): per mesh
    /// cell, lazily, which lights every node a point of the cell can use agrees on, and
    /// whether the cell's geometry is one plane. "auto" uses them for the default variant
    /// (consensus) only, so the paper's variants run the paper's algorithms, and only where
    /// a cell meets enough camera rays for them to pay (rayAngle below); "on" in every cell,
    /// also for none (Нет) and inside (СТ); "off" nowhere.
    std::string cellSummaries = "auto";
    /// The angle between neighbouring camera rays (radians: 2·tan(fov/2) / (height·aa)),
    /// filled in from the render's camera and size; 0 if unknown. With "auto" a cell's
    /// summary is used only where the image is fine enough for it to pay: where the cell
    /// spans about kMinRaysPerCell camera rays or more (see LightMesh::SummaryPays), and a
    /// cell patch only where it meets enough rays for its front triangles (PatchPays).
    float rayAngle = 0.0f;
    /// Lanes of the vectorised loops (the templates' front test, the segment culling), for
    /// tests: 1 the scalar front test (the oracle of the others), 4 SSE, 8 AVX2 where the
    /// processor has it; 0 the widest available.
    int simdWidth = 0;
    /// Contact-hardening penumbrae (ours, beyond the paper): the radius R of the spheres the
    /// point lights stand for, in scene units. With R > 0 the interpolation radius at each
    /// penumbra point follows the light's size and the blocker's distance (see
    /// LightMeshShadows); 0 is the paper's fixed radius r = kI·h. Filled from the render's
    /// explicit "light_radius" override (AreaLightOptions::radius) only, 0 without one: the
    /// lights' own radii (PointLight::radius) do not turn the mode on.
    float lightRadius = 0.0f;
    /// With a light radius (ours): where the nodes agree on a light, P's own shadow ray
    /// checks their answer, so that occluders ("lit": the points the nodes call lit) and
    /// also gaps ("all": the points they call shadowed too) thinner than the mesh step,
    /// which the nodes fall between, keep their effect; where the ray disagrees the
    /// light's disc decides. "off": the nodes' answer stands. Filled from "thin_check".
    std::string thinCheck = "all";
};

/// Settings of the area-light reference ("--shadows area"): every point light
/// becomes a sphere of its radius (same centre and intensity; LightRadii in
/// shadow/shadow.h), and each shading point traces `samples` stratified shadow rays per
/// light (the paper's "naive" soft shadows, §1.2). Lights of radius 0 get exactly the shadow
/// ray of "rt".
struct AreaLightOptions {
    /// The override of every light's radius, in scene units, finite and >= 0 (0: all lights
    /// are points): --light-radius, a scene file's "render": {"light_radius"}, or code that
    /// sets it (the bench's references). Unset: each light's own PointLight::radius. It is
    /// also the only thing that turns on the light mesh's contact-hardening penumbrae
    /// (LightMeshOptions::lightRadius).
    std::optional<float> radius;
    int samples = 16;     ///< shadow rays per light and shading point, 1 .. 4096
    /// The stream of the samples' rotations (AreaLightSeed): 0 in every render. The bench's
    /// references draw from another, so that an area row of as many rays as the reference
    /// is judged against an independent estimate, not against itself.
    uint32_t stream = 0;
};


/// Settings of the soft shadows: the default ("--shadows soft", render/soft_frame.h) and
/// the exact mode ("--shadows exact", shadow/soft_shadows.h); ours.
struct SoftShadowOptions {
    /// exact: cells across the longest side of the scene's box (the light mesh's CC).
    int cc = 64;
    /// Rays (soft) or directions (exact) per light at a point in a penumbra; 0: the
    /// method's default (kSoftFrameSamples, kExactSoftSamples). soft: 4 .. 256, a multiple
    /// of 4; exact: 16 .. 256, a multiple of 16.
    int samples = 0;
    /// Rays per light at a point of a dense cell (traced through the back-end); 0: a
    /// quarter of `samples`, at least 8.
    int denseSamples = 0;
    /// Cell lists longer than this are "dense" (at most 1024).
    int denseEntries = 512;
    /// The lights' radii, one per light: filled in by the shadow-method factory
    /// (LightRadii: --light-radius, else each light's own).
    std::vector<float> radii;
};

/// The soft default's and the exact mode's rays (directions) per light in a penumbra.
inline constexpr int kSoftFrameSamples = 16, kExactSoftSamples = 64;
/// SoftShadowOptions::samples for the soft default: the option, or its default.
inline int SoftFrameSamples(const SoftShadowOptions& o) { return o.samples ? o.samples : kSoftFrameSamples; }

struct RenderOptions {
    int width = 640;
    int height = 480;
    /// Anti-aliasing: aa × aa camera rays per pixel on a regular sub-grid.
    int aa = 1;
    /// Mirror recursion limit (1 = no reflected rays).
    int maxDepth = 5;
    /// Shadow method: "soft" (the default: soft shadows of the lights' spheres), "exact"
    /// (the same, exact per point), "none", "rt" (one shadow ray per light), "lmm" (the
    /// paper's light mesh), "area" or "denoised".
    std::string shadows = "soft";
    /// Ray-query back-end: "brute", "grid" or "embree". The default is the fastest one
    /// measured (README, Benchmarks): Embree when the build has it; the nested grid (the
    /// paper's §2, which reproduces its tables) is one flag away.
    std::string accel = kDefaultAccelerator;
    AccelOptions accelOptions;
    LightMeshOptions lightMesh;
    AreaLightOptions areaLight;
    SoftShadowOptions soft;
    /// The light cut's relative error bound (render/light_cut.h): each point's lights
    /// clustered so that no cluster's error bound exceeds this share of the point's total;
    /// 0 shades every light; below 0 (the default) is automatic: kDefaultLightCutError where
    /// kLightCutMinLights lights or more have no range, else 0. The soft default's only:
    /// every other method shades every light.
    float lightCut = -1.0f;
    /// Whether materials use their images (a scene file's "textures"; --no-textures
    /// reaches the loader instead: SceneLoadOptions::textures).
    bool textures = true;
    /// Whether mesh files referenced many times become instances (a scene file's
    /// "instancing"; --no-instancing reaches the loader: SceneLoadOptions::instancing).
    bool instancing = true;
    /// Exposure in stops: the rendered linear radiance is multiplied by 2^exposure before it
    /// is written, EXR and PNG alike (io/tonemap.h); 0 leaves it as rendered.
    float exposure = 0.0f;
    /// The tone curve of PNG output (io/tonemap.h: clamp, reinhard, aces); EXR stays linear.
    std::string tonemap = "clamp";
    /// Where each knob's value came from, by scene-file key: "scene.json /render/ki" or
    /// "--ki" (the CLI's value replaces the file's); a knob left at its default is absent.
    std::map<std::string, SourceLoc> origins;
};

/// Runs f(); a SettingError it throws comes out as an Error at the place the knob's value
/// came from ("--variant: unknown light-mesh variant ...", "scene.json /render/variant:
/// ..."), unchanged for a knob at its default.
template <typename F>
decltype(auto) NamingOrigins(const RenderOptions& options, F&& f) {
    try {
        return f();
    } catch (const SettingError& e) {
        const auto it = options.origins.find(e.Key());
        if (it == options.origins.end()) throw;
        throw Error(it->second, e.Reason());
    }
}

}  // namespace lm
