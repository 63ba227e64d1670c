// Hostile model files through the command line (issue 19): a DXF INSERT bomb, a FIFO as a
// model, a material library outside the model's folder. Each is bad input (exit 2) naming the
// file, and the database is left as it was.

#include <gtest/gtest.h>
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

}  // namespace
