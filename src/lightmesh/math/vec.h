// vec.h -- 3-vectors, colours and small helpers shared by every module.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

namespace lm {

inline constexpr float Pi = 3.14159265358979323846f;
inline constexpr float Infinity = std::numeric_limits<float>::infinity();

/// std::nextafter(x, +∞) and (x, −∞) for floats, inline: the next representable value up
/// or down (NaN and the infinity in that direction stay as they are; ±0 steps to the
/// smallest denormal). Ray ranges are narrowed by one ulp per query, and libm's
/// nextafterf is an out-of-line call on that hot path.
inline float NextFloatUp(float x) {
    if (!(x < Infinity)) return x;
    if (x == 0.0f) return std::numeric_limits<float>::denorm_min();
    const uint32_t u = std::bit_cast<uint32_t>(x);
    return std::bit_cast<float>(x > 0.0f ? u + 1 : u - 1);
}
inline float NextFloatDown(float x) { return -NextFloatUp(-x); }

/// static_cast<int>(std::floor(f)) for f within int's range, without libm's floorf (an
/// out-of-line call per coordinate on a baseline x86-64 build, ~1 % of a light-mesh
/// render's instructions): truncate, then step down where that rounded a negative value
/// up. Outside int's range (and for NaN) the result is as undefined as the cast's.
inline int FloorToInt(float f) {
    const int t = static_cast<int>(f);
    return t - (f < static_cast<float>(t));
}

/// A 3-component float vector, used for points, directions and normals alike
/// (the scene is small enough that separate types cost more clarity than they buy).
struct Vec3 {
    float x = 0, y = 0, z = 0;

    constexpr Vec3() = default;
    constexpr Vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
    explicit constexpr Vec3(float s) : x(s), y(s), z(s) {}

    // Component i (0, 1 or 2). At run time one indexed load: the chain of comparisons a
    // ternary compiles to was 4 % of a camera ray's instructions on the grid (callgrind,
    // the castle: the watertight test's axes, the packets' slicing axis are run-time
    // indices). x, y and z are consecutive floats without padding (static_assert below).
    constexpr float operator[](int i) const {
        if (std::is_constant_evaluated()) return i == 0 ? x : (i == 1 ? y : z);
        return (&x)[i];
    }
    constexpr float& operator[](int i) {
        if (std::is_constant_evaluated()) return i == 0 ? x : (i == 1 ? y : z);
        return (&x)[i];
    }

    constexpr Vec3 operator-() const { return {-x, -y, -z}; }
    constexpr Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
    constexpr Vec3& operator-=(const Vec3& o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
    constexpr Vec3& operator*=(float s) { x *= s; y *= s; z *= s; return *this; }
    constexpr bool operator==(const Vec3& o) const = default;
};
static_assert(sizeof(Vec3) == 3 * sizeof(float) && std::is_standard_layout_v<Vec3>);

constexpr Vec3 operator+(Vec3 a, const Vec3& b) { return a += b; }
constexpr Vec3 operator-(Vec3 a, const Vec3& b) { return a -= b; }
constexpr Vec3 operator*(Vec3 a, float s) { return a *= s; }
constexpr Vec3 operator*(float s, Vec3 a) { return a *= s; }
constexpr Vec3 operator/(const Vec3& a, float s) { return a * (1.0f / s); }
/// Component-wise product.
constexpr Vec3 Mul(const Vec3& a, const Vec3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }

constexpr float Dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 Cross(const Vec3& a, const Vec3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float Length(const Vec3& a) { return std::sqrt(Dot(a, a)); }
constexpr float LengthSquared(const Vec3& a) { return Dot(a, a); }
inline Vec3 Normalize(const Vec3& a) { return a / Length(a); }
constexpr Vec3 Min(const Vec3& a, const Vec3& b) {
    return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
constexpr Vec3 Max(const Vec3& a, const Vec3& b) {
    return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
constexpr Vec3 Abs(const Vec3& a) { return {std::abs(a.x), std::abs(a.y), std::abs(a.z)}; }
constexpr float MaxComponent(const Vec3& a) { return std::max(a.x, std::max(a.y, a.z)); }
/// Index of the largest component (0, 1 or 2).
constexpr int MaxDimension(const Vec3& a) {
    return (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
}
inline bool IsFinite(const Vec3& a) {
    return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}
/// Mirror direction of d about the normal n (n unit length).
constexpr Vec3 Reflect(const Vec3& d, const Vec3& n) { return d - 2.0f * Dot(d, n) * n; }

/// An orthonormal basis (s, t, n) around the unit vector n (Duff et al. 2017).
inline void CoordinateSystem(const Vec3& n, Vec3* s, Vec3* t) {
    float sign = std::copysign(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float b = n.x * n.y * a;
    *s = Vec3(1 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    *t = Vec3(b, sign + n.y * n.y * a, -n.y);
}

/// Linear RGB radiance or reflectance.
struct Color {
    float r = 0, g = 0, b = 0;

    constexpr Color() = default;
    constexpr Color(float r_, float g_, float b_) : r(r_), g(g_), b(b_) {}
    explicit constexpr Color(float s) : r(s), g(s), b(s) {}

    constexpr Color& operator+=(const Color& o) { r += o.r; g += o.g; b += o.b; return *this; }
    constexpr Color& operator*=(float s) { r *= s; g *= s; b *= s; return *this; }
    constexpr bool operator==(const Color& o) const = default;
    constexpr bool IsBlack() const { return r == 0 && g == 0 && b == 0; }
    constexpr float MaxComponent() const { return std::max(r, std::max(g, b)); }
};

constexpr Color operator+(Color a, const Color& b) { return a += b; }
constexpr Color operator*(Color a, float s) { return a *= s; }
constexpr Color operator*(float s, Color a) { return a *= s; }
constexpr Color operator*(const Color& a, const Color& b) { return {a.r * b.r, a.g * b.g, a.b * b.b}; }

}  // namespace lm
