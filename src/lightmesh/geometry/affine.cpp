#include "lightmesh/geometry/affine.h"

#include <cmath>
#include <utility>

namespace lm {

Affine Affine::Scale(const Vec3& s) {
    Affine a;
    for (int i = 0; i < 3; ++i) a.m[i][i] = s[i];
    return a;
}

Affine Affine::Rotate(const Vec3& axis, float degrees) {
    // Rodrigues' formula: R = cos·I + sin·[k]× + (1 − cos)·k kᵀ.
    const Vec3 k = Normalize(axis);
    const double rad = static_cast<double>(degrees) * 3.14159265358979323846 / 180.0;
    const float c = static_cast<float>(std::cos(rad)), s = static_cast<float>(std::sin(rad));
    const float t = 1 - c;
    Affine a;
    a.m[0][0] = c + t * k.x * k.x;
    a.m[0][1] = t * k.x * k.y - s * k.z;
    a.m[0][2] = t * k.x * k.z + s * k.y;
    a.m[1][0] = t * k.x * k.y + s * k.z;
    a.m[1][1] = c + t * k.y * k.y;
    a.m[1][2] = t * k.y * k.z - s * k.x;
    a.m[2][0] = t * k.x * k.z - s * k.y;
    a.m[2][1] = t * k.y * k.z + s * k.x;
    a.m[2][2] = c + t * k.z * k.z;
    return a;
}

Affine Affine::Translate(const Vec3& t) {
    Affine a;
    for (int i = 0; i < 3; ++i) a.m[i][3] = t[i];
    return a;
}

Affine Affine::operator*(const Affine& b) const {
    Affine r;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 4; ++j) {
            double v = j == 3 ? m[i][3] : 0.0;
            for (int k = 0; k < 3; ++k) v += static_cast<double>(m[i][k]) * b.m[k][j];
            r.m[i][j] = static_cast<float>(v);
        }
    }
    return r;
}

Vec3 Affine::ApplyPoint(const Vec3& p) const {
    return ApplyVector(p) + Vec3(m[0][3], m[1][3], m[2][3]);
}

Vec3 Affine::ApplyVector(const Vec3& v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
}

float Affine::Determinant() const {
    const double d =
        static_cast<double>(m[0][0]) *
            (static_cast<double>(m[1][1]) * m[2][2] - static_cast<double>(m[1][2]) * m[2][1]) -
        static_cast<double>(m[0][1]) *
            (static_cast<double>(m[1][0]) * m[2][2] - static_cast<double>(m[1][2]) * m[2][0]) +
        static_cast<double>(m[0][2]) *
            (static_cast<double>(m[1][0]) * m[2][1] - static_cast<double>(m[1][1]) * m[2][0]);
    return static_cast<float>(d);
}

Vec3 Affine::ApplyNormal(const Vec3& n) const {
    // Normals transform by the inverse transpose of the linear part; the cofactor matrix is
    // that times det, and the scale disappears when renormalising. Its sign is kept
    // (multiplying by sign(det)) so a normal stays on the same side.
    const float(*a)[4] = m;
    const float cof[3][3] = {
        {a[1][1] * a[2][2] - a[1][2] * a[2][1], a[1][2] * a[2][0] - a[1][0] * a[2][2],
         a[1][0] * a[2][1] - a[1][1] * a[2][0]},
        {a[0][2] * a[2][1] - a[0][1] * a[2][2], a[0][0] * a[2][2] - a[0][2] * a[2][0],
         a[0][1] * a[2][0] - a[0][0] * a[2][1]},
        {a[0][1] * a[1][2] - a[0][2] * a[1][1], a[0][2] * a[1][0] - a[0][0] * a[1][2],
         a[0][0] * a[1][1] - a[0][1] * a[1][0]}};
    const float sign = Determinant() < 0 ? -1.0f : 1.0f;
    const Vec3 r(cof[0][0] * n.x + cof[0][1] * n.y + cof[0][2] * n.z, cof[1][0] * n.x + cof[1][1] * n.y + cof[1][2] * n.z,
                 cof[2][0] * n.x + cof[2][1] * n.y + cof[2][2] * n.z);
    const float len = Length(r);
    return len > 0 ? r * (sign / len) : r;
}

void TransformMesh(TriangleMesh* mesh, const Affine& t) {
    for (Vec3& p : mesh->positions) p = t.ApplyPoint(p);
    for (Vec3& n : mesh->normals) n = t.ApplyNormal(n);
    if (t.Determinant() < 0)
        for (auto& tri : mesh->triangles) std::swap(tri[1], tri[2]);
}

}  // namespace lm
