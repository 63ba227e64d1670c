// Exit statuses through the command line: 1 for failures of the system (a database locked by
// another writer, a directory that does not exist, a full disk), 2 for bad input (a file that is
// not an abrad database). A failed command leaves the database as it was.

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <stdlib.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "abrad/visdb/store.h"
#include "file_size_limit.h"
#include "run_abrad.h"
#include "temp_dir.h"

namespace fs = std::filesystem;

namespace {

using abrad::testing::Result;
Result run(const std::string& args) { return abrad::testing::run_abrad(args); }

using abrad::testing::file_bytes;

class ExitStatus : public ::testing::Test {
  protected:
    // abrad gives up on a locked database after 200 ms instead of 10 s
    void SetUp() override { setenv("ABRAD_BUSY_TIMEOUT_MS", "200", 1); }
    void TearDown() override { unsetenv("ABRAD_BUSY_TIMEOUT_MS"); }
    fs::path path(const std::string& name) const { return m_dir / name; }
    std::string model() const {
        return std::string(ABRAD_SAMPLES) + "/paper_simple/paper_occluder.obj";
    }
    abrad::testing::TempDir m_dir{"exit"};
};

TEST_F(ExitStatus, ADatabaseLockedByAnotherWriterIsAFailure) {
    const fs::path db = path("room.visdb");
    ASSERT_EQ(run("import " + model() + " --db " + db.string()).status, 0);
    const std::string before = file_bytes(db);

    sqlite3* other = nullptr;
    ASSERT_EQ(sqlite3_open(db.string().c_str(), &other), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(other, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr), SQLITE_OK);
    for (const std::string& args :
         {"bake --bounces 0 --dm off --db " + db.string(),
          "import " + model() + " --db " + db.string(), "info --db " + db.string()}) {
        const Result r = run(args);
        EXPECT_EQ(r.status, 1) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(db.string() + ": "), std::string::npos) << r.output;
        EXPECT_NE(r.output.find("locked"), std::string::npos) << r.output;
    }
    ASSERT_EQ(sqlite3_exec(other, "ROLLBACK", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(other);

    EXPECT_EQ(file_bytes(db), before);
    const abrad::visdb::Store store =
        abrad::visdb::Store::open(db, abrad::visdb::OpenMode::ReadOnly);
    EXPECT_TRUE(store.list_bakes().empty());
    EXPECT_EQ(store.load_scene().sources.size(), 1u);
}

TEST_F(ExitStatus, ADatabaseInAMissingDirectoryIsAFailure) {
    const fs::path db = path("no-such-dir") / "room.visdb";
    const Result r = run("import " + model() + " --db " + db.string());
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find(db.string() + ": cannot open"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(db));
}

// A full disk (a file-size limit stands in for it) is a failure of the system, exit 1 naming
// the database: an import into a new database leaves no file behind (which a later command
// would take for a foreign file, bad input), a bake leaves the database as it was.
TEST_F(ExitStatus, AFullDiskIsAFailureAndLeavesNoHalfDatabase) {
    const fs::path db = path("room.visdb");
    abrad::testing::Result r;
    {
        const abrad::testing::FileSizeLimit full(4096);  // bytes: less than the empty schema
        r = run("import " + model() + " --db " + db.string());
    }
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find(db.string() + ": "), std::string::npos) << r.output;
    EXPECT_EQ(m_dir.entry_count(), 0u);  // no database, no temporary, no journal
    const Result none = run("bake --db " + db.string());
    EXPECT_EQ(none.status, 2) << none.output;
    EXPECT_NE(none.output.find("no such database"), std::string::npos) << none.output;

    ASSERT_EQ(run("import " + model() + " --db " + db.string()).status, 0);
    const std::string before = file_bytes(db);
    {
        const abrad::testing::FileSizeLimit full(before.size());  // the bake cannot grow it
        r = run("bake --bounces 0 --dm off --db " + db.string());
    }
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find(db.string() + ": "), std::string::npos) << r.output;
    EXPECT_EQ(file_bytes(db), before);
    EXPECT_EQ(m_dir.entry_count(), 1u);
}

TEST_F(ExitStatus, AFileThatIsNotADatabaseIsBadInput) {
    const fs::path db = path("notes.visdb");
    std::ofstream(db) << "these are not the tables you are looking for\n";
    const std::string before = file_bytes(db);
    for (const std::string& args : {"info --db " + db.string(), "bake --db " + db.string(),
                                    "import " + model() + " --db " + db.string()}) {
        const Result r = run(args);
        EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(db.string() + ": not an abrad visual database"), std::string::npos)
            << r.output;
    }
    EXPECT_EQ(file_bytes(db), before);
}

TEST(StoreErrorKind, FromTheSqliteResult) {
    const fs::path dir = fs::temp_directory_path() / ("abrad_kind_" + std::to_string(getpid()));
    try {
        (void)abrad::visdb::Store::open((dir / "missing" / "x.visdb").string(),
                                        abrad::visdb::OpenMode::CreateOrOpen);
        ADD_FAILURE() << "opened a database in a missing directory";
    } catch (const abrad::visdb::StoreError& e) {
        EXPECT_EQ(e.kind(), abrad::visdb::StoreError::Kind::Failure) << e.what();
    }
    try {
        (void)abrad::visdb::Store::open((dir / "absent.visdb").string(),
                                        abrad::visdb::OpenMode::ReadWrite);
        ADD_FAILURE() << "opened a missing database";
    } catch (const abrad::visdb::StoreError& e) {
        EXPECT_EQ(e.kind(), abrad::visdb::StoreError::Kind::BadInput) << e.what();
    }
}

}  // namespace

// A bake setting that the chosen settings do not use is bad input naming it (never ignored),
// before any work: the database is left as it was. The same setting where it is used bakes.
TEST_F(ExitStatus, BakeSettingsTheBakeDoesNotUseAreBadInput) {
    const fs::path db = path("room.visdb");
    ASSERT_EQ(run("import " + model() + " --db " + db.string()).status, 0);
    const std::string before = file_bytes(db);
    const struct {
        const char* args;
        const char* named;
    } cases[] = {{"--bounces 0 --converge 0.01", "--converge"},
                 {"--bounces 2 --overrelax 1.5", "--overrelax"},
                 {"--dm off --lights vertices", "--lights"},
                 {"--dm off --refine-rounds 2", "--refine-rounds"},
                 {"--refine-rounds 0 --refine-tolerance 0.05", "--refine-tolerance"},
                 {"--method zbuffer --subpixels 4", "--subpixels"}};
    for (const auto& c : cases) {
        const Result r = run("bake --db " + db.string() + " " + c.args);
        EXPECT_EQ(r.status, 2) << c.args;
        EXPECT_NE(r.output.find(c.named), std::string::npos) << c.args << ": " << r.output;
        EXPECT_NE(r.output.find("not used"), std::string::npos) << r.output;
        EXPECT_EQ(file_bytes(db), before) << c.args;
    }
    // Used: converge with --bounces converge (a coarse, quick bake)
    EXPECT_EQ(run("bake --db " + db.string() +
                  " --dm off --bounces converge --converge 0.5 --element-size 2")
                  .status,
              0);
}

// OpenImageIO is loaded at the first image call, from a module (libabrad_oiio.so), not at
// start-up: abrad does not link it, the commands without images work when the module is
// missing, and an image command then fails (exit 1, a failure of the installation, not of the
// input) naming where it looked, writing nothing.
TEST_F(ExitStatus, TheImageModuleIsLoadedOnlyByImageCommands) {
    FILE* pipe = popen(("ldd " + std::string(ABRAD_EXE) + " 2>&1").c_str(), "r");
    ASSERT_NE(pipe, nullptr);
    std::string libraries;
    char buf[4096];
    for (std::size_t n; (n = fread(buf, 1, sizeof buf, pipe)) > 0;) libraries.append(buf, n);
    ASSERT_EQ(pclose(pipe), 0) << libraries;
    EXPECT_NE(libraries.find("libc.so"), std::string::npos) << libraries;
    EXPECT_EQ(libraries.find("OpenImageIO"), std::string::npos) << libraries;

    const fs::path db = path("room.visdb");
    ASSERT_EQ(run("import " + model() + " --db " + db.string()).status, 0);
    const fs::path missing = path("no/libabrad_oiio.so");
    setenv("ABRAD_OIIO_MODULE", missing.c_str(), 1);
    const Result baked = run("bake --bounces 0 --dm off --db " + db.string());
    const Result info = run("info --db " + db.string());
    const fs::path png = path("room.png");
    const Result rendered = run("render --db " + db.string() + " --output " + png.string());
    unsetenv("ABRAD_OIIO_MODULE");
    EXPECT_EQ(baked.status, 0) << baked.output;
    EXPECT_EQ(info.status, 0) << info.output;
    EXPECT_EQ(rendered.status, 1) << rendered.output;
    EXPECT_NE(rendered.output.find(missing.string() + ": no such file"), std::string::npos)
        << rendered.output;
    EXPECT_FALSE(fs::exists(png));
    // With the module found again, the same command writes the image
    const Result again = run("render --db " + db.string() + " --output " + png.string());
    EXPECT_EQ(again.status, 0) << again.output;
    EXPECT_GT(fs::file_size(png), 0u);
}
