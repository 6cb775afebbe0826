// affine_test.cpp -- Affine's compositions and TransformMesh's normals and winding.
#include "lightmesh/geometry/affine.h"

#include <gtest/gtest.h>

namespace lm {
namespace affine_test {
namespace {

bool Near(const Vec3& a, const Vec3& b, float eps = 1e-5f) {
    return Length(a - b) <= eps;
}

TEST(Affine, ComposesScaleRotateTranslate) {
    const Affine t = Affine::Translate(Vec3(0, 1, 0)) * Affine::Rotate(Vec3(0, 2, 0), 90) *
                     Affine::Scale(Vec3(2, 1, 1));
    EXPECT_TRUE(Near(t.ApplyPoint(Vec3(1, 1, 1)), Vec3(1, 2, -2)));
    EXPECT_TRUE(Near(t.ApplyVector(Vec3(1, 0, 0)), Vec3(0, 0, -2)));
    EXPECT_NEAR(t.Determinant(), 2.0f, 1e-6f);
    EXPECT_TRUE(Near(Affine::Rotate(Vec3(0, 0, 1), 90).ApplyPoint(Vec3(1, 0, 0)), Vec3(0, 1, 0)));
}

TEST(Affine, TransformMeshUsesInverseTransposeForNormals) {
    TriangleMesh mesh;
    mesh.positions = {Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
    const Vec3 n = Normalize(Vec3(1, 1, 1));
    mesh.normals = {n, n, n};
    mesh.triangles = {{0, 1, 2}};
    mesh.materialIds = {0};
    TransformMesh(&mesh, Affine::Scale(Vec3(2, 1, 1)));
    // The plane x/2 + y + z = 1 has normal ∝ (1/2, 1, 1).
    for (const Vec3& m : mesh.normals) EXPECT_TRUE(Near(m, Normalize(Vec3(0.5f, 1, 1))));
    const Vec3 face =
        Cross(mesh.Vertex(0, 1) - mesh.Vertex(0, 0), mesh.Vertex(0, 2) - mesh.Vertex(0, 0));
    EXPECT_GT(Dot(face, mesh.normals[0]), 0);

    // A mirror keeps the normals outward and the winding consistent with them.
    TransformMesh(&mesh, Affine::Scale(Vec3(-1, 1, 1)));
    for (const Vec3& m : mesh.normals) EXPECT_TRUE(Near(m, Normalize(Vec3(-0.5f, 1, 1))));
    const Vec3 mirrored =
        Cross(mesh.Vertex(0, 1) - mesh.Vertex(0, 0), mesh.Vertex(0, 2) - mesh.Vertex(0, 0));
    EXPECT_GT(Dot(mirrored, mesh.normals[0]), 0);
}

}  // namespace
}  // namespace affine_test
}  // namespace lm
