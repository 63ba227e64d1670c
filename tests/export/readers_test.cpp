// The PLY and OBJ exports read back by an independent reader, Assimp (the importer Blender's
// and MeshLab's users meet in other tools): every face corner's position, normal and display
// colour against the bake mesh, in the frame the file says (Y up for OBJ by default).

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "abrad/export/writers.h"
#include "export_scenes.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using namespace abrad;
using namespace abrad::exporter;

namespace {

using abrad::testing::survey_mesh;
using abrad::testing::two_surfaces;

glm::dvec3 y_up(const glm::dvec3& p) { return {p.x, p.z, -p.y}; }

/// Every face corner of every mesh of `scene`, meshes in order: position (double, plus
/// `origin`), normal and colour.
struct Corner {
    glm::dvec3 position, normal;
    glm::vec3 colour;
};

std::vector<Corner> corners(const aiScene& scene, const glm::dvec3& origin) {
    std::vector<Corner> out;
    for (unsigned m = 0; m < scene.mNumMeshes; ++m) {
        const aiMesh& mesh = *scene.mMeshes[m];
        EXPECT_TRUE(mesh.HasNormals());
        EXPECT_TRUE(mesh.HasVertexColors(0));
        for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
            EXPECT_EQ(mesh.mFaces[f].mNumIndices, 3u);
            for (unsigned k = 0; k < mesh.mFaces[f].mNumIndices; ++k) {
                const unsigned i = mesh.mFaces[f].mIndices[k];
                const aiVector3D& p = mesh.mVertices[i];
                const aiVector3D& n = mesh.mNormals[i];
                const aiColor4D c = mesh.HasVertexColors(0) ? mesh.mColors[0][i] : aiColor4D();
                out.push_back({origin + glm::dvec3(p.x, p.y, p.z), glm::dvec3(n.x, n.y, n.z),
                               glm::vec3(c.r, c.g, c.b)});
            }
        }
    }
    return out;
}

/// The corners of `triangles` (in that order) as the file should hold them.
void expect_corners(const std::vector<Corner>& got, const visdb::BakeMesh& m,
                    const std::vector<std::size_t>& triangles, bool turn_y_up, double tolerance,
                    const ToneMap& tone) {
    ASSERT_EQ(got.size(), 3 * triangles.size());
    for (std::size_t t = 0; t < triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            const std::size_t i = m.triangles[triangles[t]][k];
            const Corner& c = got[3 * t + static_cast<std::size_t>(k)];
            SCOPED_TRACE("triangle " + std::to_string(triangles[t]) + " corner " +
                         std::to_string(k));
            const glm::dvec3 p = turn_y_up ? y_up(m.positions[i]) : m.positions[i];
            const glm::dvec3 n = turn_y_up ? y_up(m.normals[i]) : glm::dvec3(m.normals[i]);
            for (int a = 0; a < 3; ++a) {
                EXPECT_NEAR(c.position[a], p[a], tolerance);
                EXPECT_NEAR(c.normal[a], n[a], 1e-6);
            }
            const auto rgb = display_colour(m.radiosity[i], tone);
            for (int a = 0; a < 3; ++a)
                EXPECT_NEAR(c.colour[a], rgb[static_cast<std::size_t>(a)] / 255.0, 0.6e-4);
        }
}

const aiScene* read(Assimp::Importer& importer, const fs::path& path) {
    const aiScene* scene = importer.ReadFile(path.string(), 0);
    EXPECT_NE(scene, nullptr) << path << ": " << importer.GetErrorString();
    return scene;
}

}  // namespace

// PLY, double and float positions, binary and ASCII, Z and Y up: Assimp reads every corner.
// Assimp keeps positions in float (ai_real), so a double PLY at survey coordinates comes out
// within a float's step at 2e6 m (0.25 m) only; float positions plus the header's origin give
// the millimetres back.
TEST(ExportReaders, AssimpReadsPly) {
    const abrad::testing::TempDir dir("readers");
    const visdb::BakeMesh m = survey_mesh(true);
    const ToneMap tone{.exposure = 0.05};
    for (const auto positions : {PlyPositions::Double, PlyPositions::Float})
        for (const bool ascii : {false, true})
            for (const auto up : {UpAxis::Z, UpAxis::Y}) {
                const bool is_float = positions == PlyPositions::Float;
                const std::string name = std::string(is_float ? "float" : "double") +
                                         (ascii ? "_ascii" : "_binary") +
                                         (up == UpAxis::Y ? "_y" : "_z") + ".ply";
                SCOPED_TRACE(name);
                write_ply(dir / name, m, tone,
                          {.ascii = ascii, .comment = {}, .up = up, .positions = positions});
                Assimp::Importer importer;
                const aiScene* scene = read(importer, dir / name);
                ASSERT_NE(scene, nullptr);
                // The origin of float positions: the box centre rounded (1000001, 2000001, 12)
                glm::dvec3 origin{0.0};
                if (is_float)
                    origin = up == UpAxis::Y ? y_up({1000001, 2000001, 12})
                                             : glm::dvec3(1000001, 2000001, 12);
                expect_corners(corners(*scene, origin), m, {0, 1, 2}, up == UpAxis::Y,
                               is_float ? 1e-6 : 0.25, tone);
            }
}

// OBJ: Y up by default (OBJ's convention), Z up when asked; Assimp reads the corners grouped
// by surface, with the display colours and normals.
TEST(ExportReaders, AssimpReadsObj) {
    const abrad::testing::TempDir dir("readers");
    // Near the origin: Assimp reads OBJ positions as float (ai_real)
    visdb::BakeMesh m = survey_mesh(true);
    for (auto& p : m.positions) p -= glm::dvec3(1.0e6, 2.0e6, 0.0);
    const ToneMap tone{.exposure = 0.05};
    for (const auto up : {UpAxis::Y, UpAxis::Z}) {
        const fs::path path = dir / (up == UpAxis::Y ? "y.obj" : "z.obj");
        SCOPED_TRACE(path.filename().string());
        if (up == UpAxis::Y)
            write_obj(path, two_surfaces(), m, tone);  // the default
        else
            write_obj(path, two_surfaces(), m, tone, {.up = up});
        Assimp::Importer importer;
        const aiScene* scene = read(importer, path);
        ASSERT_NE(scene, nullptr);
        // Surface 0's triangles (0 and 2), then surface 1's
        expect_corners(corners(*scene, glm::dvec3{0.0}), m, {0, 2, 1}, up == UpAxis::Y, 1e-5, tone);
    }
}
