// light_mesh.h -- the light mesh method (LMM): visibility interpolated from a lazily
// evaluated uniform grid of nodes (Debelov & Novikov; docs/light-mesh-method.md §2-3).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "lightmesh/shadow/light_mesh_counters.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/shadow/sphere_templates.h"

namespace lm {

/// The lattice of light-mesh nodes (paper §2; method note §2). Step h = longest side of
/// the scene's box / CC; the lattice covers the box grown by ceil(kI) cells on each side
/// (and, for a whole-number kI, one node more at the far end, for the templates of points
/// on the far faces), so every interpolation sphere of radius r = kI·h around a surface
/// point has its nodes. On the longest axis there are CC + ceil(kI) + max(ceil(kI),
/// floor(kI) + 1) + 1 nodes: CC + 2·kI + 2 for a whole-number kI.
struct LightMeshLattice {
    Vec3 origin;      ///< position of node (0, 0, 0)
    float h = 0;      ///< step between nodes
    float r = 0;      ///< interpolation radius kI·h
    int nx = 0, ny = 0, nz = 0;

    /// Throws Error for CC or kI out of range or an empty box.
    static LightMeshLattice Make(const Bounds3& sceneBounds, int cc, float ki);

    uint64_t NodeCount() const { return static_cast<uint64_t>(nx) * ny * nz; }
    uint64_t Index(int i, int j, int k) const {
        return (static_cast<uint64_t>(k) * ny + static_cast<uint64_t>(j)) * nx + static_cast<uint64_t>(i);
    }
    Vec3 Node(int i, int j, int k) const {
        return origin + Vec3(static_cast<float>(i) * h, static_cast<float>(j) * h, static_cast<float>(k) * h);
    }
    Vec3 NodeAt(uint64_t index) const {
        const uint64_t i = index % nx, j = (index / nx) % ny, k = index / (static_cast<uint64_t>(nx) * ny);
        return Node(static_cast<int>(i), static_cast<int>(j), static_cast<int>(k));
    }
};

/// How the nodes within r of P are enumerated.
enum class SphereEnumeration {
    Cube,       ///< the paper's "Grid": loop over the cube around the sphere, test distances
    Templates,  ///< "Ш" (§3.1): snap P to a sub-position, walk its precomputed node list
};

/// Which candidate nodes are dropped as not seeing P (light leaks, paper §1.4).
enum class LocalVisibility {
    None,     ///< "Нет": no test
    Object,   ///< "ОТ": a segment from every candidate node to P, at every shading point
    Reduced,  ///< "У" (§3.2): segments from the boundary nodes first; only if one of them
              ///< is blocked, segments from the inner nodes too
    Inside,   ///< "СТ" (§4): drop nodes inside solids, a flag computed once per node
    Consensus,  ///< not in the paper: ОТ's result exactly, but when every candidate node has
                ///< the same visibility bits only one segment (to a node that sees P) is
                ///< needed, because any non-empty subset then averages to those bits
};

/// A variant of the paper's tables: how spheres are enumerated and how local visibility
/// is tested, with the names the CLI and the docs use.
struct LightMeshVariant {
    SphereEnumeration enumeration = SphereEnumeration::Templates;
    LocalVisibility local = LocalVisibility::Reduced;
    std::string name = "reduced";  ///< command-line name
    std::string paperName = "У";   ///< name in the paper's tables
};

/// Parses a --variant name, in ASCII or as the paper writes it: grid (Grid), templates
/// (Ш), reduced (У), none (Нет), inside (СТ), object (ОТ; the same computation as Ш), and,
/// not in the paper, grid-none (cube loop without local visibility) and consensus (ОТ's
/// image with segments only where the sphere's nodes disagree). Empty means the
/// default. Throws Error naming the choices.
LightMeshVariant ParseLightMeshVariant(std::string_view name);
/// The ASCII names ParseLightMeshVariant accepts.
std::vector<std::string> LightMeshVariantNames();
/// The default variant's name (chosen by measurement; see the README).
inline constexpr const char* kDefaultLightMeshVariant = "consensus";

/// The shadow method of formula (2): V(L_i, P) is replaced by the mean of V(L_i, x_k)
/// over the m nodes x_k within r of P, in front of the surface, and passing the local
/// visibility test; with m = 0 it falls back to one shadow ray per light.
///
/// With a light radius R > 0 (LightMeshOptions::lightRadius; ours, beyond the paper) the
/// lights stand for spheres of radius R and the penumbrae follow their size: where the
/// candidates disagree on a light, the nodes' stored blocker distances give the
/// penumbra's half-width w = R·(d_P − d_b)/d_b, and V is a kernel average of the nodes over
/// a radius following w (up to r) with P's own shadow ray at its centre, or, where w is
/// below what the lattice resolves, P's own ray where the nodes near P agree with it and
/// else 4 to 8 rays to the light's disc (DiscLightVisibility). Elsewhere V is the
/// consensus variant's, checked by P's own shadow ray (LightMeshOptions::thinCheck) so that
/// occluders and gaps thinner than the mesh step, which the nodes miss, keep their effect:
/// where that ray contradicts the nodes, the light's disc decides.
class LightMeshShadows : public ShadowMethod {
  public:
    std::string_view Name() const override { return "lmm"; }
    /// The "lmm", "cells", "penumbra" and "thin" lines of --stats, from the LightMeshCount slots.
    StatsLines CounterLines(const RenderCounters& counters) const override;

    /// A point's values by light of the mesh (at most 64 lights: one node word's).
    using LightValues = float[64];
    /// Visibility for the lights of a mask (the groups' path, light_mesh_groups.h): point i
    /// needs the lights of needed[i] (bit l: light l, of the first 64) and gets light l's
    /// value in vis[i][l]; the other entries are left as they are. Each value is the one
    /// Visibility gives. The default goes through VisibilityMany with lists.
    virtual void VisibilityOfMasks(const ShadingPoint* sps, const uint64_t* needed, LightValues* vis, size_t count,
                                   RenderCounters& counters) const;

    virtual const LightMeshLattice& Lattice() const = 0;
    virtual const LightMeshVariant& Variant() const = 0;
    /// Bytes of node storage per node (1 for up to 6 lights; LightMeshStorageBytesPerNode).
    virtual int BytesPerNode() const = 0;
    /// Distinct nodes evaluated so far.
    uint64_t NodesEvaluated() const override = 0;
    /// Whether node `index` has been evaluated (for tests of laziness).
    virtual bool IsEvaluated(uint64_t index) const = 0;
    /// The node's visibility bits (bit i: light i visible), evaluating it if need be.
    virtual uint64_t NodeVisibility(uint64_t index) const = 0;
    /// Whether the node lies inside a solid (evaluating it if need be). Only the СТ variant
    /// computes this flag; the others report false.
    virtual bool NodeInside(uint64_t index) const = 0;
    /// Penumbra mode (a light radius): the nearest blocker on the segment from node `index`
    /// to light `light`, as its parameter t in (0, 1) along it (quantised to 1/65535),
    /// evaluating the node if need be; 0 where the light is visible or without a light
    /// radius.
    virtual float NodeBlockerParameter(uint64_t index, size_t light) const = 0;
    /// The sphere templates in use (empty for the cube loop) and how they were obtained.
    virtual const TemplateLoad& Templates() const = 0;
};

/// Builds the light mesh for `scene`. Refuses, before allocating, a mesh whose node
/// storage would not fit in memory. `scene` and `accel` must outlive it.
std::unique_ptr<LightMeshShadows> CreateLightMeshShadows(const Scene& scene, const Accelerator& accel,
                                                         const LightMeshOptions& options);

/// Bytes of node storage per node for a number of lights: visibility bits plus the
/// "initialised" and "inside a solid" flags, rounded up to 1, 2, 4 or 8 bytes.
int LightMeshBytesPerNode(size_t lights);
/// All a node stores: its word and, with a light radius (penumbra mode), 2 bytes per light
/// of blocker distance.
int LightMeshStorageBytesPerNode(size_t lights, float lightRadius);

}  // namespace lm
