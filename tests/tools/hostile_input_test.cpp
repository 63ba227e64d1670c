// Hostile model files through the command line (issue 19): a DXF INSERT bomb, a FIFO as a
// model, a material library outside the model's folder, files that crash or exhaust the
// third-party readers (run in a child process). Each is bad input (exit 2) naming the file,
// and the database is left as it was.

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>

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
