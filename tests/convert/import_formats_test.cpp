// The table of model formats (convert/import.h) and import_model's dispatch from it.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "abrad/convert/import.h"
#include "temp_dir.h"

namespace abrad::convert {
namespace {

namespace fs = std::filesystem;

// The message of the ImportError that importing `path` throws.
std::string import_error(const fs::path& path) {
    try {
        (void)import_model(path, {});
    } catch (const ImportError& e) {
        return e.what();
    }
    return "(no error)";
}

TEST(ImportFormats, SupportedExtensionsAreTheReadableFormatsInTableOrder) {
    EXPECT_EQ(supported_extensions(),
              (std::vector<std::string>{"obj", "gltf", "glb", "3ds", "dae", "fbx", "dxf", "ifc",
                                        "stl", "ply", "off"}));
    std::set<std::string> seen;
    for (const ModelFormat& f : model_formats()) {
        EXPECT_FALSE(f.extensions.empty()) << f.name;
        EXPECT_EQ(f.reader == ModelReader::Unavailable, !f.note.empty()) << f.name;
        for (const std::string& e : f.extensions) {
            EXPECT_TRUE(seen.insert(e).second) << e << " listed twice";
            EXPECT_TRUE(std::none_of(e.begin(), e.end(), [](char c) { return c == '.'; })) << e;
        }
    }
}

TEST(ImportFormats, UnavailableAndUnknownFormatsAreRefusedByName) {
    const abrad::testing::TempDir scratch("convert");
    const fs::path& dir = scratch.path();
    for (const char* name : {"part.STEP", "part.stp", "part.igs"}) {
        const fs::path p = dir / name;
        std::ofstream(p) << "ISO-10303-21;\n";
        EXPECT_NE(import_error(p).find("STEP and IGES need OpenCASCADE"), std::string::npos)
            << name;
    }
    const fs::path unknown = dir / "model.xyz";
    std::ofstream(unknown) << "1 2 3\n";
    EXPECT_NE(import_error(unknown).find("unknown model format 'xyz' (abrad reads obj, gltf, glb"),
              std::string::npos)
        << import_error(unknown);
}

}  // namespace
}  // namespace abrad::convert
