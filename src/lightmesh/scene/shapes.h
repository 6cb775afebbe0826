// shapes.h -- closed solids built in code (boxes, cylinders, cones, spheres).
#pragma once

#include <cstdint>

#include "lightmesh/geometry/mesh.h"

namespace lm {

/// Appends closed, consistently oriented (outward) triangle meshes to a TriangleMesh.
/// Vertices are shared within each solid, so every edge is used by exactly two triangles:
/// the solids are what the inside-a-solid test (paper §4) assumes.
class ShapeBuilder {
  public:
    explicit ShapeBuilder(TriangleMesh* mesh) : mesh_(mesh) {}

    /// A box with centre c and half-axis vectors ex, ey, ez (right-handed).
    void OrientedBox(const Vec3& c, const Vec3& ex, const Vec3& ey, const Vec3& ez, uint32_t material);
    /// An axis-aligned box.
    void Box(const Vec3& lo, const Vec3& hi, uint32_t material);
    /// A box of square cross-section `width` running from a to b (a beam, a rail).
    void Beam(const Vec3& a, const Vec3& b, float width, uint32_t material);
    /// A capped cylinder standing on `base` along +y; `segments` sides.
    void Cylinder(const Vec3& base, float radius, float height, int segments, uint32_t material);
    /// A cone (pyramid for few segments) standing on `base` along +y, with a base cap.
    void Cone(const Vec3& base, float radius, float height, int segments, uint32_t material);
    /// A UV sphere.
    void Sphere(const Vec3& centre, float radius, int rings, int segments, uint32_t material);

  private:
    uint32_t Vertex(const Vec3& p);
    void Tri(uint32_t a, uint32_t b, uint32_t c, uint32_t material);
    TriangleMesh* mesh_;
};

}  // namespace lm
