// The checking macros of abrad/check.h: ABRAD_CHECK always, ABRAD_DCHECK as this build says
// (the test preset defines ABRAD_DCHECKS). check_off_test.cpp covers ABRAD_DCHECK compiled out.

#include "abrad/check.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace {

// The message of the std::logic_error that `f` throws ("" when it throws nothing).
template <typename F>
std::string failure_of(F f) {
    try {
        f();
    } catch (const std::logic_error& e) {
        return e.what();
    }
    return "";
}

bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}

TEST(Check, PassesSilentlyAndBuildsNoMessageWhenTheConditionHolds) {
    int messages = 0;
    const auto message = [&] {
        ++messages;
        return std::string("never built");
    };
    EXPECT_NO_THROW(ABRAD_CHECK(1 + 1 == 2, message()));
    EXPECT_EQ(messages, 0);
}

TEST(Check, ThrowsLogicErrorNamingFileLineConditionAndMessage) {
    const int surfaces = 3;
    int line = 0;
    const std::string what = failure_of([&] {
        line = __LINE__ + 1;
        ABRAD_CHECK(surfaces == 4, "expected 4 surfaces, got " + std::to_string(surfaces));
    });
    EXPECT_TRUE(contains(what, "check_test.cpp:" + std::to_string(line) + ": ")) << what;
    EXPECT_TRUE(contains(what, "check failed: surfaces == 4")) << what;
    EXPECT_TRUE(contains(what, "expected 4 surfaces, got 3")) << what;
    EXPECT_THROW(ABRAD_CHECK(false, "x"), std::logic_error);
}

TEST(Check, EvaluatesTheConditionOnceAndIsOneStatement) {
    int evaluations = 0;
    ABRAD_CHECK(++evaluations == 1, "first evaluation");
    EXPECT_EQ(evaluations, 1);
    // Safe under an if without braces: the else belongs to the if, not to the macro
    bool took_else = false;
    if (evaluations == 0)
        ABRAD_CHECK(false, "not reached");
    else
        took_else = true;
    EXPECT_TRUE(took_else);
}

#ifdef ABRAD_DCHECKS
TEST(Dcheck, OnInThisBuildActsLikeCheck) {
    int evaluations = 0;
    EXPECT_NO_THROW(ABRAD_DCHECK(++evaluations > 0, "positive"));
    EXPECT_EQ(evaluations, 1);
    const std::string what = failure_of([] { ABRAD_DCHECK(2 < 1, "order"); });
    EXPECT_TRUE(contains(what, "check failed: 2 < 1: order")) << what;
    EXPECT_TRUE(contains(what, "check_test.cpp:")) << what;
}
#else
TEST(Dcheck, OnInThisBuildActsLikeCheck) {
    GTEST_SKIP() << "built without ABRAD_DCHECKS (CMake option ABRAD_DCHECK, on in the test "
                    "preset)";
}
#endif

}  // namespace
