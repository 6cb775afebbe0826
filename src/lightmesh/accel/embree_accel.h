// embree_accel.h -- the Embree 3 back-end: Intel's BVH as the reference for speed.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "lightmesh/accel/accelerator.h"

namespace lm {

/// Ray queries through an Embree 3 scene of one triangle geometry (robust mode).
///
/// Intersect and Occluded are Embree's own (rtcIntersect1 / rtcOccluded1): closest-hit t
/// can differ from IntersectTriangle's by a few ulps, and at a shared edge Embree may report
/// the other triangle, and a ray grazing exactly a vertex or an edge may hit in Embree and
/// not in IntersectTriangle (whose tie-break hits one triangle of a closed fan, and may hit
/// none of an open one). Embree's range [tnear, tfar] is narrowed by an ulp at each end to
/// mimic our open (tMin, tMax).
///
/// CountCrossings must match brute force exactly, so Embree only offers candidates: a second
/// scene, built on the first call, holds the triangles as user primitives with slightly
/// padded boxes, and its callback runs IntersectTriangle on each triangle whose box the ray
/// meets and never stops the traversal. All rtc* calls stay in embree_accel.cpp.
class EmbreeAccel final : public Accelerator {
  public:
    /// Builds the Embree scene over `mesh`, which must outlive it. Throws Error when Embree
    /// reports a failure (e.g. an unsupported CPU or out of memory).
    explicit EmbreeAccel(const TriangleMesh& mesh);
    ~EmbreeAccel() override;
    EmbreeAccel(const EmbreeAccel&) = delete;
    EmbreeAccel& operator=(const EmbreeAccel&) = delete;

    std::string_view Name() const override { return "embree"; }
    bool Intersect(const Ray& ray, Hit* hit) const override;
    bool Occluded(const Ray& ray) const override;
    /// In packets of up to 4, 8 or 16 (rtcOccluded4/8/16) where Embree has native packet
    /// kernels for them (16: AVX-512), else ray by ray. Embree does not promise that its
    /// packet and single-ray kernels round alike, but both evaluate the same triangle test
    /// (the Plücker test's expressions, instantiated for the packet's width), and
    /// AccelBatch.SegmentsInPacketsGetTheAnswersTheyGetAlone finds them equal on rays that
    /// end on vertices, edges and faces.
    void IntersectMany(const Ray* rays, size_t count, Hit* hits) const override;
    void OccludedMany(const Ray* rays, size_t count, bool* occluded) const override;
    int CountCrossings(const Ray& ray) const override;
    AccelFigures Figures() const override;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace lm
