#include "lightmesh/util/progress.h"

#include <gtest/gtest.h>

namespace lm {
namespace progress_test {
namespace {

// The bar's time left is not promised from the first moments of the work: a tenth of a
// second and 10 % done would have said 0.9 s for what the rest of the frame makes 5 s.
TEST(ProgressSecondsLeft, NotShownBeforeEnoughWorkIsDone) {
    EXPECT_EQ(ProgressSecondsLeft(0.1, 0.1), -1);    // too early
    EXPECT_EQ(ProgressSecondsLeft(0.99, 0.5), -1);   // too early, however much is done
    EXPECT_EQ(ProgressSecondsLeft(10.0, 0.01), -1);  // too little done to extrapolate
    EXPECT_EQ(ProgressSecondsLeft(0.0, 0.0), -1);
}

TEST(ProgressSecondsLeft, FromTheMeasuredRateOnceShown) {
    EXPECT_DOUBLE_EQ(ProgressSecondsLeft(2.0, 0.5), 2.0);
    EXPECT_DOUBLE_EQ(ProgressSecondsLeft(1.0, 0.05), 19.0);
    EXPECT_DOUBLE_EQ(ProgressSecondsLeft(3.0, 0.75), 1.0);
    EXPECT_EQ(ProgressSecondsLeft(0.2, 1.0), 0.0);  // done
}

}  // namespace
}  // namespace progress_test
}  // namespace lm
