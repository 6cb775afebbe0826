// shadow.h -- the seam between the ray tracer and the ways of computing light visibility.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/util/counters.h"
#include "lightmesh/settings/options.h"
#include "lightmesh/scene/scene.h"

namespace lm {

/// A surface point being shaded.
struct ShadingPoint {
    Vec3 p;       ///< the hit point, on the surface
    Vec3 n;       ///< unit geometric normal, on the side the ray came from
    Vec3 origin;  ///< where rays leaving p start: p (on a smooth-shaded mesh lifted to its corners'
                  ///< tangent planes, geometry/shadow_terminator.h) pushed off the surface along n
    uint32_t prim = 0;  ///< the triangle p lies on (the light mesh's cell patches rely on it)
};

/// The lights a shading point needs: indices into the scene's lights, strictly ascending.
using LightIndices = std::span<const uint32_t>;

/// Named figures for --stats.
using ShadowFigures = std::vector<std::pair<std::string, std::string>>;
/// Lines for --stats, one per pair: the line's label ("lmm") and its text.
using StatsLines = std::vector<std::pair<std::string, std::string>>;

/// Computes V(L_i, P) of formula (1), or its replacement in formula (2).
class ShadowMethod {
  public:
    virtual ~ShadowMethod() = default;
    virtual std::string_view Name() const = 0;

    /// Writes the visibility in [0, 1] of the lights `lights` names (indices into the
    /// scene's lights, strictly ascending: the lights that light P, facing it and in range)
    /// to vis[k] for lights[k], k < lights.size(), and nothing else: a method's work per
    /// point follows the lights a point needs, not the scene's count. A light's value must
    /// not depend on which other lights the list holds. Must be thread-safe and
    /// deterministic: the result may depend only on the point, never on the thread or on
    /// which points were shaded before. Counts its shadow rays in counters.shadowRays and
    /// its own work in counters.method.
    virtual void Visibility(const ShadingPoint& sp, LightIndices lights, float* vis,
                            RenderCounters& counters) const = 0;

    /// Visibility for `count` points at once (the camera hits of a block of pixels): point i
    /// needs lights[i] and gets their values in vis[i][0 .. lights[i].size()-1]. Each point
    /// must get what Visibility gives it alone. The default calls Visibility point by point;
    /// hard shadows trace the points' rays to one light together (a packet).
    virtual void VisibilityMany(const ShadingPoint* sps, const LightIndices* lights, float* const* vis, size_t count,
                                RenderCounters& counters) const;

    /// Figures gathered during rendering and set-up, for --stats.
    virtual ShadowFigures Figures() const { return {}; }
    /// The method's own counts of a render (the slots of counters.method it fills), as
    /// lines for --stats; none for methods that count nothing of their own.
    virtual StatsLines CounterLines(const RenderCounters& /*counters*/) const { return {}; }
    /// Light-mesh nodes evaluated so far; 0 for methods without nodes.
    virtual uint64_t NodesEvaluated() const { return 0; }
};

/// Builds the method called `name` ("none", "rt", ...). `scene` and `accel` must
/// outlive it. Throws Error for an unknown name.
std::unique_ptr<ShadowMethod> CreateShadowMethod(std::string_view name, const Scene& scene,
                                                 const Accelerator& accel,
                                                 const RenderOptions& options);

/// The names CreateShadowMethod accepts.
std::vector<std::string> ShadowMethodNames();

/// The radius of each light's sphere (one per scene.lights entry, in scene units): the
/// override options.areaLight.radius for every light when it is set (--light-radius, a
/// scene file's "render": {"light_radius"}, or code), else the light's own
/// PointLight::radius. A sun (LightKind::Sun) keeps its far sphere's radius under an
/// override other than 0. Every method that uses the lights' sizes takes them from here, so
/// the override means the same to all of them. (The light mesh's contact-hardening mode
/// is the exception by design: only the override turns it on; LightMeshOptions::lightRadius.)
std::vector<float> LightRadii(const Scene& scene, const RenderOptions& options);

/// The shadow segment from `origin` to a point light. It stops just short of the light so
/// geometry touching the light does not count.
inline Ray LightSegment(const Vec3& origin, const Vec3& light) { return Ray{origin, light - origin, 0.0f, 1.0f - 1e-5f}; }

/// One shadow ray from sp.origin to the light: the hard-shadow visibility of formula (1).
bool LightVisible(const Accelerator& accel, const Vec3& origin, const Vec3& light);

/// LightVisible for the lights in `mask` (bit l: lights[l]; the first 64 lights of the
/// span: callers with more lights pass them 64 at a time) from one origin, traced together
/// (Accelerator::OccludedMany: a packet on Embree, 2–11 % faster RT on the 6-light garden;
/// each ray's answer is LightVisible's). Bit l of the result is set where light l of the
/// mask is visible.
uint64_t LightsVisible(const Accelerator& accel, const Vec3& origin, std::span<const PointLight> lights,
                       uint64_t mask);

/// LightsVisible for the lights `ids` (indices into `lights`, any number) from one origin,
/// 16 rays at a time: vis[k] gets 1 where lights[ids[k]] is visible, else 0.
void LightsVisible(const Accelerator& accel, const Vec3& origin, std::span<const PointLight> lights, LightIndices ids,
                   float* vis);

/// LightsVisible for many points at once, light by light: for each light, the shadow rays
/// of the points whose mask has it go to the back-end together, 64 at a time (rays from
/// neighbouring points to one light are coherent: a packet on Embree, the grid's coherent
/// traversal). visible[i] gets bit l where light l is seen from sps[i].origin; each ray's
/// answer is LightVisible's. Returns the number of rays traced.
/// Like LightsVisible, the lights of the span are its first 64.
uint64_t LightsVisibleMany(const Accelerator& accel, const ShadingPoint* sps, size_t count,
                           std::span<const PointLight> lights, const uint64_t* masks, uint64_t* visible);

}  // namespace lm
