// affine.h -- affine transforms (scale, rotation, translation, a scene file's matrix) and a
// whole mesh transformed by one, normals and winding included.
#pragma once

#include "lightmesh/geometry/mesh.h"
#include "lightmesh/math/vec.h"

namespace lm {

/// An affine transform p ↦ A·p + t: the top three rows of a row-major 4×4 matrix
/// (the fourth row is implicitly 0 0 0 1).
struct Affine {
    float m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};

    static Affine Scale(const Vec3& s);
    /// Rotation by `degrees` about `axis` (any non-zero length), counter-clockwise when
    /// the axis points at the viewer (right-handed).
    static Affine Rotate(const Vec3& axis, float degrees);
    static Affine Translate(const Vec3& t);

    /// The composition "first b, then this": (a * b)(p) = a(b(p)).
    Affine operator*(const Affine& b) const;
    Vec3 ApplyPoint(const Vec3& p) const;
    Vec3 ApplyVector(const Vec3& v) const;
    /// A shading normal through the inverse transpose of the linear part, renormalised,
    /// on the same side of its surface under a mirroring transform (zero stays zero).
    Vec3 ApplyNormal(const Vec3& n) const;
    /// Determinant of the linear 3×3 part (negative: the transform mirrors).
    float Determinant() const;
};

/// Transforms every position by `t` and every normal by the inverse transpose of its
/// linear part (renormalised). A mirroring transform (determinant < 0) also reverses each
/// triangle's winding, so geometric normals keep pointing the same way relative to the
/// surface. Precondition: t is invertible.
void TransformMesh(TriangleMesh* mesh, const Affine& t);

}  // namespace lm
