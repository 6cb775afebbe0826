// brute_force.h -- every ray against every triangle: the test oracle for the other back-ends.
#pragma once

#include "lightmesh/accel/accelerator.h"

namespace lm {

/// Tests each query against all triangles in order. Slow, obviously right, kept forever
/// as the reference the differential tests compare the grid and Embree against.
class BruteForceAccel final : public Accelerator {
  public:
    explicit BruteForceAccel(const TriangleMesh& mesh) : mesh_(mesh) {}

    std::string_view Name() const override { return "brute"; }
    bool Intersect(const Ray& ray, Hit* hit) const override;
    bool Occluded(const Ray& ray) const override;
    int CountCrossings(const Ray& ray) const override;
    AccelFigures Figures() const override;

  private:
    const TriangleMesh& mesh_;
};

}  // namespace lm
