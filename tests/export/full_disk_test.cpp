// Every writer on a full disk (a file-size limit stands in for it): ExportError
// "PATH: cannot write: File too large", the old file byte for byte as it was, and no
// temporary left beside it. Then, with room, the same call replaces the file.

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "abrad/export/image.h"
#include "abrad/export/writers.h"
#include "export_scenes.h"
#include "file_size_limit.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using namespace abrad;
using namespace abrad::exporter;

namespace {

// One lit floor triangle and one wall triangle.
visdb::BakeMesh small_mesh() {
    visdb::BakeMesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {1, 0, 0}, {1, 0, 0}, {1, 0, 0}};
    m.triangles = {{0, 1, 2}, {3, 5, 4}};
    m.triangle_surface = {0, 1};
    m.radiosity = {{10, 20, 30}, {1, 2, 3}, {0, 0, 0}, {5, 5, 5}, {50, 0, 0}, {0, 0, 500}};
    m.irradiance = m.radiosity;
    return m;
}

using abrad::testing::two_surfaces;

struct Writer {
    const char* file;
    std::function<void(const fs::path&)> write;
};

}  // namespace

TEST(FullDisk, EveryWriterFailsNamingThePathAndKeepsTheOldFile) {
    const visdb::BakeMesh mesh = small_mesh();
    const visdb::Scene scene = two_surfaces();
    const ToneMap tone{.exposure = 0.1};
    const std::vector<float> rgb(std::size_t{16} * 16 * 3, 0.5f);
    const std::vector<Writer> writers = {
        {"image.png", [&](const fs::path& p) { write_image(p, 16, 16, rgb); }},
        {"image.exr", [&](const fs::path& p) { write_image(p, 16, 16, rgb); }},
        {"bake.gltf", [&](const fs::path& p) { write_gltf(p, scene, mesh, tone); }},
        {"bake.glb", [&](const fs::path& p) { write_gltf(p, scene, mesh, tone); }},
        {"bake.ply", [&](const fs::path& p) { write_ply(p, mesh, tone); }},
        {"bake.obj", [&](const fs::path& p) { write_obj(p, scene, mesh, tone); }},
    };
    for (const Writer& w : writers) {
        SCOPED_TRACE(w.file);
        const abrad::testing::TempDir dir("fulldisk");
        const fs::path path = dir.write(w.file, "the old file\n");
        std::string message;
        {
            const abrad::testing::FileSizeLimit full(16);  // bytes
            try {
                w.write(path);
            } catch (const ExportError& e) {
                message = e.what();
            }
        }
        EXPECT_EQ(message, path.string() + ": cannot write: File too large");
        EXPECT_EQ(abrad::testing::file_bytes(path), "the old file\n");
        EXPECT_EQ(dir.entry_count(), 1u);  // no temporary left

        w.write(path);  // with room
        EXPECT_GT(fs::file_size(path), 16u);
    }
}
