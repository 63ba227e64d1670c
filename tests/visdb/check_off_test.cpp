// ABRAD_DCHECK compiled out (as in the release preset), whatever this build defines: the
// condition and the message are never evaluated and nothing is thrown, while ABRAD_CHECK stays.

#undef ABRAD_DCHECKS
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "abrad/check.h"

namespace {

TEST(DcheckOff, NeverEvaluatesConditionOrMessage) {
    int evaluations = 0;
    int messages = 0;
    const auto message = [&] {
        ++messages;
        return std::string("never built");
    };
    EXPECT_NO_THROW(ABRAD_DCHECK(++evaluations < 0, message()));
    EXPECT_EQ(evaluations, 0);
    EXPECT_EQ(messages, 0);
}

TEST(DcheckOff, CheckIsStillOn) { EXPECT_THROW(ABRAD_CHECK(false, "always on"), std::logic_error); }

}  // namespace
