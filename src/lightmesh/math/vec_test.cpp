#include "lightmesh/math/vec.h"

#include <bit>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "lightmesh/math/bounds.h"
#include "lightmesh/math/ray.h"

namespace lm {
namespace vec_test {
namespace {

TEST(Vec3, ArithmeticAndProducts) {
    const Vec3 a(1, 2, 3), b(-4, 5, 0.5f);
    EXPECT_EQ(a + b, Vec3(-3, 7, 3.5f));
    EXPECT_EQ(a - b, Vec3(5, -3, 2.5f));
    EXPECT_EQ(a * 2.0f, Vec3(2, 4, 6));
    EXPECT_FLOAT_EQ(Dot(a, b), -4 + 10 + 1.5f);
    // The cross product is orthogonal to both and follows the right-hand rule.
    EXPECT_EQ(Cross(Vec3(1, 0, 0), Vec3(0, 1, 0)), Vec3(0, 0, 1));
    EXPECT_FLOAT_EQ(Dot(Cross(a, b), a), 0);
    EXPECT_FLOAT_EQ(Dot(Cross(a, b), b), 0);
    EXPECT_FLOAT_EQ(Length(Normalize(b)), 1.0f);
    EXPECT_EQ(MaxDimension(Vec3(1, -7, 3)), 2);
    EXPECT_EQ(MaxDimension(Abs(Vec3(1, -7, 3))), 1);
}

TEST(Vec3, ReflectKeepsTangentAndFlipsNormal) {
    const Vec3 r = Reflect(Vec3(1, -1, 0), Vec3(0, 1, 0));
    EXPECT_EQ(r, Vec3(1, 1, 0));
}

TEST(Vec3, CoordinateSystemIsOrthonormal) {
    for (Vec3 n : {Vec3(0, 0, 1), Vec3(0, 0, -1), Normalize(Vec3(1, 2, 3)), Normalize(Vec3(-1, 0.1f, -0.2f))}) {
        Vec3 s, t;
        CoordinateSystem(n, &s, &t);
        EXPECT_NEAR(Length(s), 1, 1e-6);
        EXPECT_NEAR(Length(t), 1, 1e-6);
        EXPECT_NEAR(Dot(s, t), 0, 1e-6);
        EXPECT_NEAR(Dot(s, n), 0, 1e-6);
        EXPECT_NEAR(Dot(t, n), 0, 1e-6);
    }
}

TEST(Bounds3, EmptyExtendContains) {
    Bounds3 b;
    EXPECT_TRUE(b.IsEmpty());
    EXPECT_EQ(b.MaxExtent(), 0);
    b.Extend(Vec3(1, 2, 3));
    b.Extend(Vec3(-1, 0, 5));
    EXPECT_FALSE(b.IsEmpty());
    EXPECT_EQ(b.lo, Vec3(-1, 0, 3));
    EXPECT_EQ(b.hi, Vec3(1, 2, 5));
    EXPECT_TRUE(b.Contains(Vec3(0, 1, 4)));
    EXPECT_FALSE(b.Contains(Vec3(0, 1, 6)));
    EXPECT_EQ(b.MaxExtent(), 2);
}

TEST(Ray, SegmentSpansZeroToOne) {
    const Ray r = Segment(Vec3(1, 1, 1), Vec3(3, 1, 1));
    EXPECT_EQ(r.At(r.tMax), Vec3(3, 1, 1));
    EXPECT_EQ(r.At(0.5f), Vec3(2, 1, 1));
}

// FloorToInt is the floor's cast on every kind of float within int's range: whole numbers
// (where the truncation must not step down), ±0, halves, values an ulp either side of a
// whole number, denormals, negatives, and the range's ends.
TEST(Vec3, FloorToIntIsTheFloorsCast) {
    const float specials[] = {0.0f, -0.0f, 0.5f, -0.5f, 1.0f, -1.0f, 0.99999994f, -0.99999994f, 1.0000001f,
                              -1.0000001f, std::numeric_limits<float>::denorm_min(),
                              -std::numeric_limits<float>::denorm_min(), 1e-30f, -1e-30f, 8388607.5f, -8388607.5f,
                              16777216.0f, -16777216.0f, 2147483520.0f, -2147483648.0f};
    for (float x : specials) EXPECT_EQ(FloorToInt(x), static_cast<int>(std::floor(x))) << x;
    uint32_t bits = 777;
    int tested = 0;
    for (int i = 0; i < 200000; ++i) {
        bits = bits * 1664525u + 1013904223u;
        const float x = std::bit_cast<float>(bits);
        if (!(std::abs(x) < 2147483520.0f)) continue;  // NaN, ±∞ and beyond int's range: undefined for both
        ++tested;
        ASSERT_EQ(FloorToInt(x), static_cast<int>(std::floor(x))) << x;
    }
    EXPECT_GT(tested, 100000);
}

// NextFloatUp/Down are std::nextafter towards ±∞, bit for bit, on every kind of float.
TEST(Vec3, NextFloatUpAndDownAreNextafter) {
    const float specials[] = {0.0f, -0.0f, 1.0f, -1.0f, 1e-30f, -1e-30f, std::numeric_limits<float>::denorm_min(),
                              -std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::min(),
                              std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(), Infinity,
                              -Infinity, 0.99999994f, 3.0e7f};
    auto same = [](float a, float b) { return std::bit_cast<uint32_t>(a) == std::bit_cast<uint32_t>(b); };
    for (float x : specials) {
        EXPECT_TRUE(same(NextFloatUp(x), std::nextafter(x, Infinity))) << x;
        EXPECT_TRUE(same(NextFloatDown(x), std::nextafter(x, -Infinity))) << x;
    }
    uint32_t bits = 12345;
    for (int i = 0; i < 100000; ++i) {
        bits = bits * 1664525u + 1013904223u;
        const float x = std::bit_cast<float>(bits);
        if (std::isnan(x)) {
            EXPECT_TRUE(std::isnan(NextFloatUp(x)) && std::isnan(NextFloatDown(x)));
            continue;
        }
        ASSERT_TRUE(same(NextFloatUp(x), std::nextafter(x, Infinity))) << x;
        ASSERT_TRUE(same(NextFloatDown(x), std::nextafter(x, -Infinity))) << x;
    }
}

}  // namespace
}  // namespace vec_test
}  // namespace lm
