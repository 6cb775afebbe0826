#include "lightmesh/io/tonemap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace lm {
namespace tonemap_test {
namespace {

TEST(Tonemap, ExposureScalesByPowersOfTwo) {
    Image image(2, 1);
    image.pixels[0] = Color(1.0f, 0.5f, 3.0f);
    image.pixels[1] = Color(0.0f, 8.0f, 0.25f);
    Image halved = image;
    ApplyExposure(&halved, -1);
    EXPECT_EQ(halved.pixels[0], Color(0.5f, 0.25f, 1.5f));
    EXPECT_EQ(halved.pixels[1], Color(0.0f, 4.0f, 0.125f));
    Image same = image;
    ApplyExposure(&same, 0);
    EXPECT_EQ(same.pixels[0], image.pixels[0]);
    EXPECT_EQ(same.pixels[1], image.pixels[1]);
    ApplyExposure(&same, 2);
    EXPECT_EQ(same.pixels[0], Color(4.0f, 2.0f, 12.0f));
}

TEST(Tonemap, ClampIsTheIdentityBelowOne) {
    for (float x : {0.0f, 0.001f, 0.25f, 0.5f, 0.999f, 1.0f}) EXPECT_EQ(ToneMap(x, "clamp"), x);
    EXPECT_EQ(ToneMap(4.0f, "clamp"), 1.0f);
    Image image(1, 1);
    image.pixels[0] = Color(0.3f, 2.0f, 0.7f);
    ApplyToneCurve(&image, "clamp");  // the PNG encoder clamps: the image is left as it is
    EXPECT_EQ(image.pixels[0], Color(0.3f, 2.0f, 0.7f));
}

// Narkowicz's fit: a bright value stays below white, the curve never falls, 0 is black.
TEST(Tonemap, AcesMapsBrightValuesBelowOneMonotonically) {
    EXPECT_EQ(ToneMap(0.0f, "aces"), 0.0f);
    EXPECT_LT(ToneMap(2.0f, "aces"), 1.0f);
    EXPECT_NEAR(ToneMap(2.0f, "aces"), 10.1f / 11.04f, 1e-5f);  // 2(2.51·2 + 0.03) / (2(2.43·2 + 0.59) + 0.14)
    EXPECT_LT(ToneMap(1.0f, "aces"), 1.0f);
    EXPECT_EQ(ToneMap(1e6f, "aces"), 1.0f);
    EXPECT_EQ(ToneMap(std::numeric_limits<float>::infinity(), "aces"), 1.0f);
    EXPECT_EQ(ToneMap(std::nanf(""), "aces"), 0.0f);
    EXPECT_EQ(ToneMap(-1.0f, "aces"), 0.0f);
    for (const std::string& curve : ToneCurveNames()) {
        SCOPED_TRACE(curve);
        float previous = 0;
        for (float x = 0; x < 20; x += 0.01f) {
            const float y = ToneMap(x, curve);
            EXPECT_GE(y, previous) << x;
            EXPECT_LE(y, 1.0f) << x;
            previous = y;
        }
    }
    EXPECT_NEAR(ToneMap(1.0f, "reinhard"), 0.5f, 1e-7f);
}

TEST(Tonemap, UnknownCurveIsAnError) {
    Image image(1, 1);
    EXPECT_THROW(ApplyToneCurve(&image, "filmic"), std::exception);
}

}  // namespace
}  // namespace tonemap_test
}  // namespace lm
