// Outputs through the command line on a full disk (a file-size limit stands in for it, so the
// tests run the same as root): every file abrad writes fails with exit status 1 naming the
// path, the old file byte for byte as it was and no temporary beside it; `run` leaves the
// previous results of its output folder as they were.

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "file_size_limit.h"
#include "run_abrad.h"
#include "temp_dir.h"

namespace fs = std::filesystem;

namespace {

using abrad::testing::file_bytes;
using abrad::testing::FileSizeLimit;
using abrad::testing::Result;

Result run(const std::string& args) { return abrad::testing::run_abrad(args); }

std::string model() { return std::string(ABRAD_SAMPLES) + "/paper_simple/paper_occluder.obj"; }

// Every entry of `dir` (not recursive) and its bytes ("(folder)" for a folder).
std::map<std::string, std::string> snapshot(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const fs::directory_entry& e : fs::directory_iterator(dir))
        files[e.path().filename().string()] = e.is_directory() ? "(folder)" : file_bytes(e.path());
    return files;
}

class Outputs : public ::testing::Test {
  protected:
    void SetUp() override {
        ASSERT_EQ(run("import " + model() + " --db " + m_db).status, 0);
        ASSERT_EQ(run("bake --bounces 0 --dm off --db " + m_db).status, 0);
    }
    abrad::testing::TempDir m_dir{"outputs"};
    std::string m_db = m_dir.file("room.visdb");
};

TEST_F(Outputs, AFullDiskFailsEveryOutputNamingItAndKeepsTheOldFile) {
    const std::string view = " --width 64 --height 48";
    const struct {
        const char* file;
        std::string args;
    } cases[] = {
        {"image.png", "render --db " + m_db + view}, {"image.exr", "render --db " + m_db + view},
        {"bake.gltf", "export --db " + m_db},        {"bake.glb", "export --db " + m_db},
        {"bake.ply", "export --db " + m_db},         {"bake.obj", "export --db " + m_db},
        {"bake.pov", "export --db " + m_db + view},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.file);
        const fs::path path = m_dir.write(c.file, "the old file\n");
        const auto before = snapshot(m_dir.path());
        Result r;
        {
            const FileSizeLimit full(16);  // bytes
            r = run(c.args + " --output " + path.string());
        }
        EXPECT_EQ(r.status, 1) << r.output;
        EXPECT_NE(r.output.find(path.string() + ": cannot write: File too large"),
                  std::string::npos)
            << r.output;
        EXPECT_EQ(r.output.find("wrote"), std::string::npos) << r.output;
        EXPECT_EQ(snapshot(m_dir.path()), before);  // the old file, the database, nothing more

        // With room the same command replaces the file
        const Result ok = run(c.args + " --output " + path.string());
        EXPECT_EQ(ok.status, 0) << ok.output;
        EXPECT_NE(file_bytes(path), "the old file\n");
    }
}

TEST_F(Outputs, AFullDiskFailsTheConvergenceCurveAndStoresNoBake) {
    const fs::path csv = m_dir.write("curve.csv", "the old curve\n");
    const auto before = snapshot(m_dir.path());
    const std::string args = "bake --db " + m_db +
                             " --dm off --bounces converge --converge 0.5 --element-size 2 "
                             "--convergence-csv " +
                             csv.string();
    Result r;
    {
        const FileSizeLimit full(16);
        r = run(args);
    }
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find(csv.string() + ": cannot write: File too large"), std::string::npos)
        << r.output;
    EXPECT_EQ(snapshot(m_dir.path()), before);

    const Result ok = run(args);
    EXPECT_EQ(ok.status, 0) << ok.output;
    EXPECT_EQ(file_bytes(csv).rfind("shots,seconds,unshot_fraction\n", 0), 0u);
}

// run makes everything before it moves anything into its folder, the database last: when
// its last step fails (the image, whose name is taken by a folder), the previous run's
// database and exports are there byte for byte, and nothing else (no staging folder).
TEST_F(Outputs, AFailedRunLeavesThePreviousResults) {
    const fs::path out = m_dir / "out";
    const std::string args = "run --bounces 0 --dm off " + model() + " --out " + out.string();
    const Result first = run(args);
    ASSERT_EQ(first.status, 0) << first.output;
    const fs::path png = out / "paper_occluder.png";
    fs::remove(png);
    fs::create_directories(png / "taken");
    const auto before = snapshot(out);
    ASSERT_EQ(before.count("paper_occluder.visdb"), 1u);
    ASSERT_EQ(before.count("paper_occluder.ply"), 1u);

    // A killed run's staging folder (no such process) is cleared; a failed run leaves none
    fs::create_directories(out / ".abrad-run-2147483647" / "left");
    const Result r = run(args + " --name second");
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find(png.string() + ": cannot write: "), std::string::npos) << r.output;
    EXPECT_EQ(snapshot(out), before);
    EXPECT_TRUE(fs::is_directory(png / "taken"));
}

}  // namespace
