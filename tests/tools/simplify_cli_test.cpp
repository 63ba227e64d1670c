// abrad simplify and abrad export --simplify through the command line: a simplified bake of
// the paper room is stored, has fewer triangles, and its field error against the exact direct
// field stays within the bound of the bake's own; bad bounds are refused (exit 2) and leave
// the database as it was.

#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <string>
#include <utility>

#include "run_abrad.h"

namespace fs = std::filesystem;

namespace {

using abrad::testing::Result;
Result run(const std::string& args) { return abrad::testing::run_abrad(args); }

// The number after "key: " in `text`, or NaN.
double value_of(const std::string& text, const std::string& key) {
    const std::size_t at = text.find("\n" + key + ": ");
    if (at == std::string::npos) return std::nan("");
    return std::stod(text.substr(at + key.size() + 3));
}

// One direct-light bake with discontinuity meshing of the paper room for the whole suite, as
// meshed (--coarsen 0: the light meshes are measured against the full discontinuity mesh).
class SimplifyCli : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        s_dir = fs::temp_directory_path() / ("abrad_simplify_" + std::to_string(getpid()));
        fs::remove_all(s_dir);
        fs::create_directories(s_dir);
        s_db = (s_dir / "room.visdb").string();
        const Result baked = abrad::testing::import_and_bake_paper_room(
            s_db, "--bounces 0 --coarsen 0 --name direct");
        ASSERT_EQ(baked.status, 0) << baked.output;
    }
    static void TearDownTestSuite() { fs::remove_all(s_dir); }

    // The triangles and field error (4 x 4 samples a triangle) of the source bake and of
    // bake `name`, each as {triangles, relative L1}.
    static std::pair<std::array<double, 2>, std::array<double, 2>> compare(
        const std::string& name) {
        const Result before = run("field-error --db " + s_db + " --bake direct --subdivisions 4");
        const Result after =
            run("field-error --db " + s_db + " --bake " + name + " --subdivisions 4");
        EXPECT_EQ(before.status, 0) << before.output;
        EXPECT_EQ(after.status, 0) << after.output;
        return {{value_of(before.output, "triangles"), value_of(before.output, "relative_l1")},
                {value_of(after.output, "triangles"), value_of(after.output, "relative_l1")}};
    }

    static fs::path s_dir;
    static std::string s_db;
};

fs::path SimplifyCli::s_dir;
std::string SimplifyCli::s_db;

TEST_F(SimplifyCli, SimplifiedBakeKeepsTheFieldErrorWithinTheBound) {
    constexpr double kError = 0.02;
    const Result simplified =
        run("simplify --db " + s_db + " --bake direct --error 0.02 --name light");
    ASSERT_EQ(simplified.status, 0) << simplified.output;
    EXPECT_NE(simplified.output.find("stored bake 'light'"), std::string::npos)
        << simplified.output;
    const auto [before, after] = compare("light");
    const auto [triangles_before, error_before] = before;
    const auto [triangles_after, error_after] = after;
    EXPECT_LT(triangles_after, 0.75 * triangles_before);
    EXPECT_LE(error_after, error_before + kError);
    // The export's shortcut writes the same light mesh without storing it, with its refit
    // and budget off
    const std::string ply = (s_dir / "light.ply").string();
    const Result exported = run("export --db " + s_db +
                                " --bake direct --simplify 0.02 --simplify-refit false "
                                "--simplify-budget 0 --output " +
                                ply);
    ASSERT_EQ(exported.status, 0) << exported.output;
    EXPECT_NE(
        exported.output.find(std::to_string(static_cast<long>(triangles_after)) + " triangles"),
        std::string::npos)
        << exported.output;
}

// The light-mesh recipe of docs/benchmarks.md (refit, an area-weighted budget, no per-vertex
// cap): at least 5x fewer triangles for no more than half a point of field error.
TEST_F(SimplifyCli, BudgetWithRefitGivesFiveTimesFewerTriangles) {
    const Result simplified = run("simplify --db " + s_db +
                                  " --bake direct --error 1 --refit true --budget 0.004 "
                                  "--name budget");
    ASSERT_EQ(simplified.status, 0) << simplified.output;
    EXPECT_NE(simplified.output.find("area-weighted change"), std::string::npos)
        << simplified.output;
    const auto [before, after] = compare("budget");
    EXPECT_LE(after[0], before[0] / 5) << after[0] << " triangles of " << before[0];
    EXPECT_LE(after[1], before[1] + 0.005) << "field error " << after[1] << " of " << before[1];
    const Result info = run("info --db " + s_db);
    EXPECT_NE(info.output.find("simplify_budget"), std::string::npos) << info.output;
    // The export's light mesh is this one by default
    const std::string glb = (s_dir / "budget.glb").string();
    const Result exported =
        run("export --db " + s_db + " --bake direct --simplify 1 --output " + glb);
    ASSERT_EQ(exported.status, 0) << exported.output;
    EXPECT_NE(exported.output.find(std::to_string(static_cast<long>(after[0])) + " triangles"),
              std::string::npos)
        << exported.output;
    EXPECT_NE(exported.output.find("refit true, budget 0.004"), std::string::npos)
        << exported.output;
}

TEST_F(SimplifyCli, BadBoundsAreRefused) {
    const Result info_before = run("info --db " + s_db);
    ASSERT_EQ(info_before.status, 0);
    const std::string ply = (s_dir / "bad.ply").string();
    for (const std::string value : {"0", "-0.1", "1.5", "nan", "inf", "abc", ""}) {
        const Result e =
            run("export --db " + s_db + " --output " + ply + " --simplify '" + value + "'");
        EXPECT_EQ(e.status, 2) << value << "\n" << e.output;
        EXPECT_NE(e.output.find("--simplify"), std::string::npos) << e.output;
        const Result s = run("simplify --db " + s_db + " --error '" + value + "' --name bad");
        EXPECT_EQ(s.status, 2) << value << "\n" << s.output;
        EXPECT_NE(s.output.find("--error"), std::string::npos) << s.output;
    }
    EXPECT_FALSE(fs::exists(ply));
    const Result floor = run("simplify --db " + s_db + " --error 0.1 --floor 2 --name bad");
    EXPECT_EQ(floor.status, 2) << floor.output;
    EXPECT_NE(floor.output.find("--floor"), std::string::npos) << floor.output;
    const Result budget = run("simplify --db " + s_db + " --error 0.1 --budget 1.5 --name bad");
    EXPECT_EQ(budget.status, 2) << budget.output;
    EXPECT_NE(budget.output.find("--budget"), std::string::npos) << budget.output;
    const Result itself = run("simplify --db " + s_db + " --bake direct --error 0.1 --name direct");
    EXPECT_EQ(itself.status, 2) << itself.output;
    const Result missing = run("simplify --db " + s_db + " --bake nonesuch --error 0.1");
    EXPECT_EQ(missing.status, 2) << missing.output;
    for (const std::string option : {"--simplify-floor 2", "--simplify-budget 1.5",
                                     "--simplify-budget -0.1", "--simplify-floor nan"}) {
        const Result e =
            run("export --db " + s_db + " --output " + ply + " --simplify 0.1 " + option);
        EXPECT_EQ(e.status, 2) << option << "\n" << e.output;
        EXPECT_NE(e.output.find(option.substr(0, option.find(' '))), std::string::npos) << e.output;
    }
    const Result alone =
        run("export --db " + s_db + " --output " + ply + " --simplify-refit false");
    EXPECT_EQ(alone.status, 2) << alone.output;
    EXPECT_NE(alone.output.find("give --simplify"), std::string::npos) << alone.output;
    EXPECT_FALSE(fs::exists(ply));
    const Result reference = run("export --db " + s_db + " --format pov-reference --output " +
                                 (s_dir / "r.pov").string() + " --simplify 0.1");
    EXPECT_EQ(reference.status, 2) << reference.output;
    EXPECT_NE(reference.output.find("--simplify applies to"), std::string::npos)
        << reference.output;
    EXPECT_EQ(run("info --db " + s_db).output, info_before.output);
}

}  // namespace
