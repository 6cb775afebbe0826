// light_mesh_groups.h -- the light mesh with more lights than one node word holds: the
// lights in groups of at most kMaxLightsPerWord, nearby lights together, each group a light
// mesh of its own over the same lattice (node words of 62 lights, 8 bytes, per group). A
// point asks only the groups that hold a light it needs (facing it, in range). Private to
// the light mesh (light_mesh.cpp and its tests).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "lightmesh/shadow/light_mesh.h"

namespace lm {

/// Lights one node word holds: 64 bits less the "initialised" and "inside" flags.
inline constexpr size_t kMaxLightsPerWord = 62;

/// The scene's lights in groups of at most `perGroup` (as equal as can be): one group of all
/// lights in their order when they fit; else ordered along a Morton curve through the
/// lights' box, so that lights near each other share a group (a point in range of few lights
/// then asks few groups), cut into consecutive runs; within a group, in the scene's order.
/// Depends on the lights only.
std::vector<std::vector<uint32_t>> LightGroups(const std::vector<PointLight>& lights, size_t perGroup);

/// One light mesh for `lights` (a group, or all the scene's lights), its words sized to them.
/// With `tables`, the geometry's tables (triangle planes, the bricks' lists) are taken from
/// *tables when set (a previous group of the same scene, lattice and options) and left there.
std::unique_ptr<LightMeshShadows> CreateLightMeshForLights(const Scene& scene, const Accelerator& accel,
                                                           const LightMeshLattice& lattice, const LightMeshVariant& variant,
                                                           TemplateLoad templates, const LightMeshOptions& options,
                                                           std::vector<PointLight> lights,
                                                           std::shared_ptr<void>* tables = nullptr);

/// The light mesh of many lights: meshes[g] holds the lights groups[g] (scene indices).
std::unique_ptr<LightMeshShadows> CreateLightMeshGroups(const Scene& scene, std::vector<std::vector<uint32_t>> groups,
                                                        std::vector<std::unique_ptr<LightMeshShadows>> meshes);

}  // namespace lm
