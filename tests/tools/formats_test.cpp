// abrad export's formats through the command line: the output's extension picks the format, a
// --format that contradicts the extension is refused, and so is an option the chosen format
// does not use (exit 2, naming the option and the format).

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "run_abrad.h"

namespace fs = std::filesystem;

namespace {

using abrad::testing::Result;
Result run(const std::string& args) { return abrad::testing::run_abrad(args); }

std::string head(const fs::path& p, std::size_t n) {
    std::ifstream in(p, std::ios::binary);
    std::string s(n, '\0');
    in.read(s.data(), static_cast<std::streamsize>(n));
    s.resize(static_cast<std::size_t>(in.gcount()));
    return s;
}

// One baked database for the whole suite (the bake is the slow part).
class Formats : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        s_dir = fs::temp_directory_path() / ("abrad_formats_" + std::to_string(getpid()));
        fs::remove_all(s_dir);
        fs::create_directories(s_dir);
        s_db = (s_dir / "room.visdb").string();
        const Result baked =
            abrad::testing::import_and_bake_paper_room(s_db, "--bounces 0 --dm off");
        ASSERT_EQ(baked.status, 0) << baked.output;
    }
    static void TearDownTestSuite() { fs::remove_all(s_dir); }

    static fs::path path(const std::string& name) { return s_dir / name; }
    static Result export_to(const std::string& name, const std::string& options = {}) {
        return run("export --db " + s_db + " --output " + path(name).string() + " " + options);
    }

    static fs::path s_dir;
    static std::string s_db;
};

fs::path Formats::s_dir;
std::string Formats::s_db;

TEST_F(Formats, TheExtensionPicksTheFormat) {
    const struct {
        const char* file;
        const char* format;  // as the report names it
        const char* magic;   // the file's first bytes
    } cases[] = {
        {"a.ply", "(ply,", "ply\n"}, {"a.PLY", "(ply,", "ply\n"}, {"a.obj", "(obj,", "#"},
        {"a.gltf", "(gltf,", "{"},   {"a.glb", "(gltf,", "glTF"}, {"a.pov", "(pov,", "//"},
    };
    for (const auto& c : cases) {
        const Result r = export_to(c.file);
        ASSERT_EQ(r.status, 0) << c.file << "\n" << r.output;
        EXPECT_NE(r.output.find(c.format), std::string::npos) << c.file << "\n" << r.output;
        const std::string magic = c.magic;
        EXPECT_EQ(head(path(c.file), magic.size()), magic) << c.file;
    }
    // An explicit --format that agrees with the extension, and pov-reference (which only an
    // explicit --format picks: .pov alone is the bake)
    EXPECT_EQ(export_to("b.ply", "--format ply --ascii").status, 0);
    const Result ref = export_to("ref.pov", "--format pov-reference --light-samples 4");
    EXPECT_EQ(ref.status, 0) << ref.output;
    EXPECT_NE(ref.output.find("(pov-reference,"), std::string::npos) << ref.output;
    // An extension no format has needs --format, which then writes it
    const Result unknown = export_to("a.dat");
    EXPECT_EQ(unknown.status, 2) << unknown.output;
    EXPECT_NE(unknown.output.find("a.dat: cannot tell the format from the extension '.dat'"),
              std::string::npos)
        << unknown.output;
    EXPECT_NE(unknown.output.find("give --format"), std::string::npos) << unknown.output;
    EXPECT_FALSE(fs::exists(path("a.dat")));
    EXPECT_EQ(export_to("c.dat", "--format ply").status, 0);
    EXPECT_EQ(head(path("c.dat"), 4), "ply\n");
}

TEST_F(Formats, AFormatContradictingTheExtensionIsRefused) {
    const struct {
        const char* file;
        const char* options;
        const char* message;
    } cases[] = {
        {"x.ply", "--format obj", "--format obj contradicts the extension of "},
        {"x.glb", "--format ply", "--format ply contradicts the extension of "},
        {"x.obj", "--format pov-reference", "--format pov-reference contradicts the extension of "},
        {"x.pov", "--format gltf", "--format gltf contradicts the extension of "},
    };
    for (const auto& c : cases) {
        const Result r = export_to(c.file, c.options);
        EXPECT_EQ(r.status, 2) << c.file << " " << c.options << "\n" << r.output;
        EXPECT_NE(r.output.find(std::string("abrad export: ") + c.message + path(c.file).string()),
                  std::string::npos)
            << r.output;
        EXPECT_FALSE(fs::exists(path(c.file))) << c.file;
    }
    // The message names the format the extension stands for
    const Result r = export_to("y.ply", "--format obj");
    EXPECT_NE(r.output.find("'.ply' is ply"), std::string::npos) << r.output;
}

TEST_F(Formats, AnOptionTheFormatDoesNotUseIsRefused) {
    const struct {
        const char* file;
        const char* options;
        const char* message;
    } cases[] = {
        {"o.obj", "--ascii", "--ascii applies to --format ply only; --format obj does not use it"},
        {"o.glb", "--camera top",
         "--camera applies to --format pov and pov-reference only; --format gltf does not use it"},
        {"o.ply", "--width 100",
         "--width applies to --format pov and pov-reference only; --format ply does not use it"},
        {"o.pov", "--quality high",
         "--quality applies to --format pov-reference only; --format pov does not use it"},
        {"o.pov", "--format pov --reference-bounces 2",
         "--reference-bounces applies to --format pov-reference only; --format pov does not use "
         "it"},
        {"o.dat", "--format obj --light-samples 8",
         "--light-samples applies to --format pov-reference only; --format obj does not use it"},
        {"o.gltf", "--up z",
         "--up applies to --format ply and obj only; --format gltf does not use it"},
        {"o.obj", "--positions float",
         "--positions applies to --format ply only; --format obj does not use it"},
    };
    for (const auto& c : cases) {
        const Result r = export_to(c.file, c.options);
        EXPECT_EQ(r.status, 2) << c.file << " " << c.options << "\n" << r.output;
        EXPECT_NE(r.output.find(std::string("abrad export: ") + c.message), std::string::npos)
            << r.output;
        EXPECT_FALSE(fs::exists(path(c.file))) << c.file;
    }
}

}  // namespace

// OBJ is written Y up by default (OBJ's convention), Z up with --up z; PLY --positions float
// --up y writes float positions with an origin line.
TEST_F(Formats, UpAxisAndPlyPositions) {
    ASSERT_EQ(export_to("y.obj").status, 0);
    ASSERT_EQ(export_to("z.obj", "--up z").status, 0);
    const auto first_v = [](const fs::path& p) {
        std::ifstream in(p);
        for (std::string line; std::getline(in, line);)
            if (line.rfind("v ", 0) == 0) return line;
        return std::string();
    };
    std::istringstream y(first_v(path("y.obj"))), z(first_v(path("z.obj")));
    std::string tag;
    double yx = 0, yy = 0, yz = 0, zx = 0, zy = 0, zz = 0;
    y >> tag >> yx >> yy >> yz;
    z >> tag >> zx >> zy >> zz;
    EXPECT_EQ(yx, zx);
    EXPECT_EQ(yy, zz);  // Y up: (x, y, z) -> (x, z, -y)
    EXPECT_EQ(yz, -zy);
    const Result r = export_to("f.ply", "--positions float --up y --ascii");
    ASSERT_EQ(r.status, 0) << r.output;
    const std::string h = head(path("f.ply"), 400);
    EXPECT_NE(h.find("comment origin 0 0 0\nelement vertex"), std::string::npos) << h;
    EXPECT_NE(h.find("property float x\nproperty float y\nproperty float z\n"), std::string::npos)
        << h;
    const Result bad = export_to("g.ply", "--positions half");
    EXPECT_EQ(bad.status, 2) << bad.output;
}
