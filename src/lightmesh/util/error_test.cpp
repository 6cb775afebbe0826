// Tests of Error and SourceLoc: the place of an error is data, and the message is made from it.
#include "lightmesh/util/error.h"

#include <gtest/gtest.h>

namespace lm {
namespace error_test {
namespace {

TEST(SourceLoc, FormatsAsMessagesWriteIt) {
    EXPECT_EQ(SourceLoc().Format(), "");
    EXPECT_FALSE(SourceLoc().Known());
    EXPECT_EQ(SourceLoc("mesh.obj").Format(), "mesh.obj");
    EXPECT_EQ(SourceLoc("scene.json", 3, 14).Format(), "scene.json:3:14");
    EXPECT_EQ(SourceLoc("scene.json", 3).Format(), "scene.json:3");
    EXPECT_EQ(SourceLoc("scene.json", 0, 0, "/lights/1/position").Format(), "scene.json /lights/1/position");
    EXPECT_EQ(SourceLoc("", 0, 0, "/cc").Format(), "/cc");
    EXPECT_TRUE(SourceLoc("", 0, 0, "/cc").Known());
}

TEST(Error, KeepsItsPlaceAndReasonApart) {
    const Error at(SourceLoc("scene.json", 0, 0, "/lights/1/position"), "expected 3 numbers");
    EXPECT_STREQ(at.what(), "scene.json /lights/1/position: expected 3 numbers");
    EXPECT_EQ(at.Where().file, "scene.json");
    EXPECT_EQ(at.Where().jsonPath, "/lights/1/position");
    EXPECT_EQ(at.Reason(), "expected 3 numbers");

    const Error plain("--ki: must be between 0.01 and 16, got 0");
    EXPECT_FALSE(plain.Where().Known());
    EXPECT_EQ(plain.Reason(), plain.what());

    // No place: the reason alone. Control characters are shown, in both.
    const Error nowhere(SourceLoc(), "bad\x1b[31m");
    EXPECT_STREQ(nowhere.what(), "bad<U+001B>[31m");
    EXPECT_EQ(nowhere.Reason(), "bad<U+001B>[31m");

    // A newline in a file name does not split the one-line message, and a NUL byte is
    // shown, not a cut.
    const Error named(SourceLoc("a\nb.json", 0, 0, "/x"), std::string("bad \"v\0x\"", 9));
    EXPECT_STREQ(named.what(), "a<U+000A>b.json /x: bad \"v<U+0000>x\"");
    EXPECT_EQ(Printable("tab\tstays"), "tab\tstays");
    EXPECT_EQ(Printable("cr\r"), "cr<U+000D>");

    try {
        ThrowErrorAt(SourceLoc("t.lmt"), "truncated (%d bytes)", 7);
        FAIL() << "no throw";
    } catch (const Error& e) {
        EXPECT_STREQ(e.what(), "t.lmt: truncated (7 bytes)");
        EXPECT_EQ(e.Where().file, "t.lmt");
        EXPECT_EQ(e.Reason(), "truncated (7 bytes)");
    }
}

}  // namespace
}  // namespace error_test
}  // namespace lm
