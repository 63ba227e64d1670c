#pragma once
// The shared test data folder (CAD models and broken files written by others, outside this
// repository: ABRAD_SHARED_DATA, by default ../shared/data). A checkout may not have it, so a
// test that needs it starts with
//
//     ABRAD_REQUIRE_SHARED_DATA("ifc/AC14-FZK-Haus.ifc");
//
// which skips the test (GTEST_SKIP) with a message naming the missing path. The argument is
// relative to the folder; "" asks for the folder itself. The environment variable
// ABRAD_SHARED_DATA, when set, replaces the folder chosen at configure time (so
// `ABRAD_SHARED_DATA=/nowhere ctest ...` shows which tests need it).

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#ifndef ABRAD_SHARED_DATA
#error "ABRAD_SHARED_DATA must be defined (link the test to abrad_test_common)"
#endif

namespace abrad::testing {

/// The shared data folder, or `relative` inside it.
inline std::filesystem::path shared_data(const std::string& relative = "") {
    const char* env = std::getenv("ABRAD_SHARED_DATA");
    const std::filesystem::path root{env != nullptr && *env != '\0' ? env : ABRAD_SHARED_DATA};
    return relative.empty() ? root : root / relative;
}

}  // namespace abrad::testing

/// Skips the current test when shared_data(relative) does not exist. Use in the test body (or
/// SetUp) only: GTEST_SKIP returns from the enclosing function.
#define ABRAD_REQUIRE_SHARED_DATA(relative)                                                    \
    do {                                                                                       \
        const std::filesystem::path abrad_required_ = ::abrad::testing::shared_data(relative); \
        if (!std::filesystem::exists(abrad_required_))                                         \
            GTEST_SKIP() << "shared test data not found: " << abrad_required_.string()         \
                         << " (set ABRAD_SHARED_DATA)";                                        \
    } while (false)
