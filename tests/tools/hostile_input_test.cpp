// Hostile model files through the command line (issue 19): a DXF INSERT bomb, a FIFO as a
// model, a material library outside the model's folder, files that crash or exhaust the
// third-party readers (run in a child process). Each is bad input (exit 2) naming the file,
// and the database is left as it was.

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>

#include <cstdint>
#include <filesystem>
#include <string>

#include "abrad/visdb/store.h"
#include "hostile_files.h"
#include "run_abrad.h"
#include "temp_dir.h"

namespace fs = std::filesystem;

namespace {

using abrad::testing::file_bytes;
using abrad::testing::Result;
using abrad::testing::run_abrad;
using abrad::testing::TempDir;

const std::string kTriangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

TEST(HostileInput, RefusedWithExitTwoAndTheDatabaseUnchanged) {
    TempDir dir("hostile");
    const fs::path db = dir / "room.visdb";
    fs::create_directories(dir / "model");
    const fs::path good = dir.write("model/good.obj", kTriangle);
    ASSERT_EQ(run_abrad("import " + good.string() + " --db " + db.string()).status, 0);
    const std::string before = file_bytes(db);

    const std::string bomb_text = abrad::testing::dxf_insert_bomb("BEEF");
    const fs::path bomb = dir.write("model/bomb.dxf", bomb_text);
    const fs::path fifo = dir / "model/fifo.obj";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    (void)dir.write("secret.txt", "secret-token 42\n");
    const fs::path outside = dir.write("model/outside.obj", "mtllib ../secret.txt\n" + kTriangle);
    struct Case {
        fs::path model;
        std::string message;
    };
    for (const Case& c :
         {Case{bomb, bomb.string() + ":" +
                         std::to_string(abrad::testing::line_of(bomb_text, "0\nINSERT\n5\nBEEF")) +
                         ": INSERT of block 'B2' (handle BEEF) expands"},
          Case{fifo, fifo.string() + ": is not a regular file"},
          Case{outside, outside.string() + ":1: material library '"}}) {
        const Result r = run_abrad("import " + c.model.string() + " --db " + db.string());
        EXPECT_EQ(r.status, 2) << c.model << "\n" << r.output;
        EXPECT_NE(r.output.find("abrad import: " + c.message), std::string::npos) << r.output;
        EXPECT_EQ(r.output.find("secret-token"), std::string::npos) << r.output;
        EXPECT_EQ(file_bytes(db), before) << c.model;
    }

    // --allow-outside-refs reads it, and a file that is not a material library still fails
    // without showing its content
    const Result r =
        run_abrad("import " + outside.string() + " --allow-outside-refs --db " + db.string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("not a material library"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("secret-token"), std::string::npos) << r.output;
    EXPECT_EQ(file_bytes(db), before);
    (void)dir.write("lib.mtl", "newmtl outside\nKd 0.3 0.3 0.3\n");
    const fs::path allowed =
        dir.write("model/allowed.obj", "mtllib ../lib.mtl\nusemtl outside\n" + kTriangle);
    const Result ok =
        run_abrad("import " + allowed.string() + " --allow-outside-refs --db " + db.string());
    EXPECT_EQ(ok.status, 0) << ok.output;
}

TEST(HostileInput, AReaderThatCrashesIsExitTwoAndTheDatabaseUnchanged) {
    TempDir dir("hostile");
    const fs::path db = dir / "room.visdb";
    const fs::path good = dir.write("good.obj", kTriangle);
    ASSERT_EQ(run_abrad("import " + good.string() + " --db " + db.string()).status, 0);
    const std::string before = file_bytes(db);

    // Assimp's glTF JSON parser overflowed its stack on 200,000 levels of nesting
    const fs::path deep = dir.write("deep.gltf", abrad::testing::deep_gltf());
    const Result r = run_abrad("import " + deep.string() + " --db " + db.string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("abrad import: " + deep.string() + ": the glTF reader failed ("),
              std::string::npos)
        << r.output;
    EXPECT_EQ(file_bytes(db), before);

    // toml++ overflowed its stack on a table header of 100,000 dotted keys
    std::string header = "[a";
    for (int i = 0; i < 100000; ++i) header += ".a";
    const fs::path scene = dir.write("deep.toml", header + "]\nx = 1\n");
    const Result t = run_abrad("import " + good.string() + " --scene " + scene.string() + " --db " +
                               db.string());
    EXPECT_EQ(t.status, 2) << t.output;
    EXPECT_NE(t.output.find("abrad import: " + scene.string() + ": "), std::string::npos)
        << t.output;
    EXPECT_EQ(file_bytes(db), before);
}

// An OpenEXR header (version 2, scan lines, no compression) claiming width x height pixels of
// three half channels, and its table of scan-line offsets (all 0), without any pixels.
std::string exr_header(int width, int height) {
    std::string h("\x76\x2f\x31\x01\x02\x00\x00\x00", 8);
    auto i32 = [](std::int32_t v) {
        std::string b(4, '\0');
        for (int k = 0; k < 4; ++k) b[k] = static_cast<char>((v >> (8 * k)) & 0xFF);
        return b;
    };
    auto attribute = [&](const std::string& name, const std::string& type,
                         const std::string& value) {
        h += name + '\0' + type + '\0' + i32(static_cast<std::int32_t>(value.size())) + value;
    };
    std::string channels;
    for (const char* c : {"B", "G", "R"})  // half (1), pLinear 0, reserved, x/y sampling 1
        channels += std::string(c) + '\0' + i32(1) + std::string(4, '\0') + i32(1) + i32(1);
    channels += '\0';
    const std::string window = i32(0) + i32(0) + i32(width - 1) + i32(height - 1);
    const std::string one = i32(0x3f800000);  // 1.0f
    attribute("channels", "chlist", channels);
    attribute("compression", "compression", std::string(1, '\0'));
    attribute("dataWindow", "box2i", window);
    attribute("displayWindow", "box2i", window);
    attribute("lineOrder", "lineOrder", std::string(1, '\0'));
    attribute("pixelAspectRatio", "float", one);
    attribute("screenWindowCenter", "v2f", i32(0) + i32(0));
    attribute("screenWindowWidth", "float", one);
    h += '\0';
    h += std::string(8 * static_cast<std::size_t>(height), '\0');  // the scan lines' offsets
    return h;
}

// A glTF whose buffer lies outside the model's folder: Assimp opened any file the model named
// (issue 19). Refused like an OBJ's mtllib unless --allow-outside-refs.
TEST(HostileInput, AGltfBufferOutsideTheModelsFolderIsRefused) {
    TempDir dir("hostile");
    const fs::path db = dir / "room.visdb";
    fs::create_directories(dir / "model");
    std::string triangle(36, '\0');  // (0,0,0) (1,0,0) (0,1,0) as little-endian floats
    triangle[12 + 2] = triangle[24 + 6] = '\x80';
    triangle[12 + 3] = triangle[24 + 7] = '\x3f';
    (void)dir.write("outside.bin", triangle);
    const fs::path gltf = dir.write(
        "model/tri.gltf",
        R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"accessors":[{)"
        R"("bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],)"
        R"("max":[1,1,0]}],"bufferViews":[{"buffer":0,"byteLength":36}],)"
        R"("buffers":[{"uri":"../outside.bin","byteLength":36}]})");
    const Result r = run_abrad("import " + gltf.string() + " --db " + db.string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("abrad import: " + gltf.string() +
                            ": referenced file (buffer, texture or library) '"),
              std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("is outside the model's folder"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(db));
    const Result ok =
        run_abrad("import " + gltf.string() + " --allow-outside-refs --db " + db.string());
    EXPECT_EQ(ok.status, 0) << ok.output;
}

// A truncated .gltf said only "No suitable reader found" (issue 19): the JSON is checked
// first, and the message names the line and column where it breaks
TEST(HostileInput, ABrokenGltfNamesTheLineAndColumn) {
    TempDir dir("hostile");
    const fs::path db = dir / "room.visdb";
    const fs::path cut =
        dir.write("cut.gltf", "{\n\"asset\": {\"version\": \"2.0\"},\n\"scenes\": [{\"no");
    const fs::path bad =
        dir.write("bad.gltf", "{\n\"asset\": {\"version\": \"2.0\"},\n  \"scene\": 0,,\n}");
    for (const auto& [model, where] :
         {std::pair{cut, cut.string() + ":3: column 16 (byte 46): not valid glTF JSON: "},
          std::pair{bad, bad.string() + ":3: column 14 (byte 44): not valid glTF JSON: "}}) {
        const Result r = run_abrad("import " + model.string() + " --db " + db.string());
        EXPECT_EQ(r.status, 2) << r.output;
        EXPECT_NE(r.output.find("abrad import: " + where), std::string::npos) << r.output;
        EXPECT_FALSE(fs::exists(db));
    }
}

// compare allocated the pixels an EXR header claimed (10^6 x 48 in a file of a few hundred
// bytes: gigabytes, issue 19): the claimed size is checked against the file's size first
TEST(HostileInput, AnImageHeaderClaimingMorePixelsThanItsFileHoldsIsRefused) {
    TempDir dir("hostile");
    const fs::path bomb = dir.write("bomb.exr", exr_header(1000000, 48));
    const fs::path small = dir.write("small.exr", exr_header(4, 4));
    const Result r = run_abrad("compare " + bomb.string() + " " + small.string());
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find(bomb.string() + ": the image header claims 1000000x48 pixels of 3 "
                                            "channels"),
              std::string::npos)
        << r.output;
    // A small header without its pixels is still the reader's error (exit 2), not this one
    const Result s = run_abrad("compare " + small.string() + " " + small.string());
    EXPECT_EQ(s.status, 2) << s.output;
    EXPECT_EQ(s.output.find("claims"), std::string::npos) << s.output;
}

// Numbers that overflowed the bake to inf/NaN with exit 0 (issue 19)
TEST(HostileInput, NumbersOutOfRangeAreRefused) {
    TempDir dir("hostile");
    const fs::path db = dir / "room.visdb";
    (void)dir.write("room.mtl", "newmtl lamp\nKd 0.5 0.5 0.5\nKe 1e300 1 1\n");
    const std::string lamp = "mtllib room.mtl\nusemtl lamp\n" + kTriangle;
    const fs::path huge = dir.write("huge.obj", lamp);
    const Result e = run_abrad("import " + huge.string() + " --db " + db.string());
    EXPECT_EQ(e.status, 2) << e.output;
    EXPECT_NE(e.output.find((dir / "room.mtl").string() + ":3: Ke (emittance) over 1e10 W/m2"),
              std::string::npos)
        << e.output;
    EXPECT_FALSE(fs::exists(db));

    // A database edited to rho = 2 is refused by the bake, naming the material
    (void)dir.write("room.mtl", "newmtl lamp\nKd 0.5 0.5 0.5\nKe 10 10 10\n");
    ASSERT_EQ(run_abrad("import " + huge.string() + " --db " + db.string()).status, 0);
    sqlite3* c = nullptr;
    ASSERT_EQ(sqlite3_open(db.string().c_str(), &c), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(c, "UPDATE materials SET rho_r = 2", nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(c);
    const std::string before = file_bytes(db);
    const Result b = run_abrad("bake --db " + db.string() + " --dm off --bounces 0");
    EXPECT_EQ(b.status, 2) << b.output;
    EXPECT_NE(b.output.find("material 'lamp': reflectance (2.000000, 0.500000, 0.500000) is not "
                            "in [0, 1)"),
              std::string::npos)
        << b.output;
    EXPECT_EQ(file_bytes(db), before);

    // --exposure must be a finite number > 0 (CLI::PositiveNumber let nan through)
    for (const char* k : {"nan", "inf", "0", "-1"}) {
        const Result x = run_abrad("render --db " + db.string() + " --camera none --output " +
                                   (dir / "x.png").string() + " --exposure " + k);
        EXPECT_EQ(x.status, 2) << k << "\n" << x.output;
        EXPECT_NE(x.output.find("must be a finite number > 0"), std::string::npos) << x.output;
    }
}

}  // namespace
