// abrad generate and abrad bench from the command line: outputs, values, and bad input (exit 2).

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "run_abrad.h"
#include "temp_dir.h"

namespace {

namespace fs = std::filesystem;

using Outcome = ::abrad::testing::Result;

Outcome abrad(const std::string& args) { return ::abrad::testing::run_abrad(args); }

class BenchCli : public ::testing::Test {
  protected:
    std::string path(const std::string& name) const { return m_dir.file(name); }
    // This test's own folder, removed when it passes (temp_dir.h)
    abrad::testing::TempDir m_dir{"bench_cli"};
};

TEST_F(BenchCli, GenerateWritesAFloorThatBakes) {
    const std::string db = path("floor.visdb");
    const Outcome g =
        abrad("generate --db " + db + " --rooms 2 1 --cell 1 --furniture 1 --lights 2");
    ASSERT_EQ(g.status, 0) << g.output;
    const Outcome info = abrad("info --db " + db);
    ASSERT_EQ(info.status, 0) << info.output;
    // Two rooms, two 0.6 m panels each: 8 light triangles, 1.44 m², 144 W at 100 W/m²
    EXPECT_NE(info.output.find("lights: 8 triangles, 1.44 m2, 144 W"), std::string::npos)
        << info.output;
    const Outcome b = abrad("bake --db " + db + " --dm off --bounces 0 --reach 6");
    ASSERT_EQ(b.status, 0) << b.output;
    EXPECT_NE(b.output.find("8 light triangles"), std::string::npos) << b.output;
}

TEST_F(BenchCli, BadInputExitsTwo) {
    EXPECT_EQ(abrad("generate --db " + path("a.visdb") + " --rooms 0 1").status, 2);
    EXPECT_EQ(abrad("generate --db " + path("a.visdb") + " --cell -1").status, 2);
    EXPECT_EQ(abrad("generate --db " + path("a.visdb") + " --lights 17").status, 2);
    EXPECT_FALSE(fs::exists(path("a.visdb")));
    const Outcome s = abrad("bench --out " + path("b") + " --sizes 3q");
    EXPECT_EQ(s.status, 2);
    EXPECT_NE(s.output.find("--sizes"), std::string::npos) << s.output;
    EXPECT_EQ(abrad("bench --out " + path("b") + " --subdivisions 0").status, 2);
    EXPECT_EQ(abrad("bench --out " + path("b") + " --no-room").status, 2);
    EXPECT_EQ(abrad("bench --out " + path("b") + " --quick --reach -1").status, 2);
    EXPECT_EQ(abrad("bench --out " + path("b") + " --quick --tradeoff 0.07,1").status, 2);
    EXPECT_EQ(abrad("bake --db " + path("a.visdb") + " --reach -2").status, 2);
}

TEST_F(BenchCli, QuickBenchWritesCsvSummaryAndPlots) {
    const std::string out = path("bench");
    const Outcome r = abrad("bench --out " + out +
                            " --quick --no-room --sizes 600 --light-counts 1,2 --lights-at 600 "
                            "--dm off --bounces 0 --subdivisions 1");
    ASSERT_EQ(r.status, 0) << r.output;
    std::ifstream csv(out + "/scaling.csv");
    std::string line;
    int rows = 0;
    while (std::getline(csv, line)) ++rows;
    EXPECT_EQ(rows, 1 + 3);  // header, one size, two light counts
    std::stringstream md;
    md << std::ifstream(out + "/summary.md").rdbuf();
    EXPECT_NE(md.str().find("## Scaling with light triangles"), std::string::npos);
    // The PNG through gnuplot, or a notice saying it was not made
    if (!fs::exists(out + "/scaling.png")) {
        EXPECT_NE(r.output.find("gnuplot"), std::string::npos) << r.output;
    }
    EXPECT_TRUE(fs::exists(out + "/scaling.gp"));
}

// A whole building (here the paper's room) is baked once with the bake options, interreflection
// on, and reported in scaling.csv and the summary with its stages and its energy balance.
TEST_F(BenchCli, BuildingRowsReportStagesAndEnergy) {
    const std::string out = path("building");
    const Outcome r =
        abrad("bench --out " + out + " --no-room --building " + std::string(ABRAD_SAMPLES) +
              "/paper_simple/paper_occluder.obj --dm off --element-size 1");
    ASSERT_EQ(r.status, 0) << r.output;
    std::ifstream csv(out + "/scaling.csv");
    std::string header, row, extra;
    ASSERT_TRUE(std::getline(csv, header));
    ASSERT_TRUE(std::getline(csv, row));
    EXPECT_FALSE(std::getline(csv, extra));  // one building, no floors
    const auto cells = [](const std::string& line) {
        std::vector<std::string> c;
        std::string cell;
        std::stringstream ss(line);
        while (std::getline(ss, cell, ',')) c.push_back(cell);
        return c;
    };
    const std::vector<std::string> names = cells(header), values = cells(row);
    ASSERT_EQ(names.size(), values.size()) << row;
    const auto value = [&](const std::string& name) {
        for (std::size_t i = 0; i < names.size(); ++i)
            if (names[i] == name) return values[i];
        ADD_FAILURE() << "no column " << name;
        return std::string();
    };
    EXPECT_EQ(value("kind"), "building");
    EXPECT_GT(std::stod(value("indirect_elements")), 0.0);
    EXPECT_GT(std::stod(value("indirect_rows")), 0.0);
    EXPECT_GT(std::stod(value("seconds_cpu")), 0.0);
    const double emitted = std::stod(value("energy_emitted_w"));
    EXPECT_GT(emitted, 0.0);
    EXPECT_NEAR(std::stod(value("energy_absorbed_w")) + std::stod(value("energy_escaped_w")) +
                    std::stod(value("energy_unshot_w")),
                emitted, 1e-4 * emitted);
    std::stringstream md;
    md << std::ifstream(out + "/summary.md").rdbuf();
    EXPECT_NE(md.str().find("## Whole buildings"), std::string::npos);
    EXPECT_NE(md.str().find("paper_occluder.obj"), std::string::npos);
}

}  // namespace
