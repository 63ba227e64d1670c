// Concurrent use of one database through the command line: two bakes at once both stored
// under distinct names, two imports of one file at once store it once, a bake whose database
// stays busy at commit keeps its result in a file beside it, and a database that cannot be
// written is refused before the bake's work.

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "abrad/visdb/store.h"
#include "run_abrad.h"
#include "temp_dir.h"

namespace fs = std::filesystem;

namespace {

using abrad::testing::file_bytes;
using abrad::testing::Result;
using abrad::visdb::OpenMode;
using abrad::visdb::Store;

Result run(const std::string& args) { return abrad::testing::run_abrad(args); }

std::string model() { return std::string(ABRAD_SAMPLES) + "/paper_simple/paper_occluder.obj"; }

// Runs `command` (a shell command line, stdout and stderr captured) for each entry, all at
// once as child processes, and returns their results in order.
std::vector<Result> run_at_once(const std::vector<std::string>& commands) {
    std::vector<FILE*> pipes;
    pipes.reserve(commands.size());
    for (const std::string& c : commands) pipes.push_back(popen((c + " 2>&1").c_str(), "r"));
    std::vector<Result> results;
    results.reserve(pipes.size());
    for (FILE* pipe : pipes) {
        if (pipe == nullptr) {
            results.push_back({-1, "popen failed"});
            continue;
        }
        std::string out;
        char buf[4096];
        std::size_t n = 0;
        while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
        const int status = pclose(pipe);
        results.push_back({WIFEXITED(status) ? WEXITSTATUS(status) : -1, out});
    }
    return results;
}

std::string abrad(const std::string& args) { return std::string(ABRAD_EXE) + " " + args; }

class Concurrency : public ::testing::Test {
  protected:
    // abrad gives up on a busy database after 200 ms instead of 10 s
    void SetUp() override { setenv("ABRAD_BUSY_TIMEOUT_MS", "200", 1); }
    void TearDown() override { unsetenv("ABRAD_BUSY_TIMEOUT_MS"); }
    abrad::testing::TempDir m_dir{"concurrency"};
    std::string m_db = m_dir.file("room.visdb");
};

// Both bakes are numbered inside their write transaction: neither takes the other's name,
// neither replaces the other. (With the busy timeout of 10 s the second writer waits for the
// first.)
TEST_F(Concurrency, TwoBakesAtOnceAreBothStoredUnderDistinctNames) {
    unsetenv("ABRAD_BUSY_TIMEOUT_MS");
    ASSERT_EQ(run("import " + model() + " --db " + m_db).status, 0);
    const std::string bake = abrad("bake --bounces 0 --dm off --db " + m_db);
    const std::vector<Result> r = run_at_once({bake, bake});
    for (const Result& one : r) EXPECT_EQ(one.status, 0) << one.output;
    std::set<std::string> names;
    for (const auto& summary : Store::open(m_db, OpenMode::ReadOnly).list_bakes())
        names.insert(summary.name);
    EXPECT_EQ(names, (std::set<std::string>{"bake-1", "bake-2"}));
    // Each reported the name it was stored under
    for (const std::string& name : names) {
        const bool reported = r[0].output.find("bake '" + name + "'") != std::string::npos ||
                              r[1].output.find("bake '" + name + "'") != std::string::npos;
        EXPECT_TRUE(reported) << name << "\n" << r[0].output << "\n" << r[1].output;
    }
}

// The duplicate check is inside the import's transaction: one import stores the file, the
// other is refused as bad input.
TEST_F(Concurrency, TwoImportsOfOneFileAtOnceStoreItOnce) {
    unsetenv("ABRAD_BUSY_TIMEOUT_MS");
    const std::string import = abrad("import " + model() + " --db " + m_db);
    const std::vector<Result> r = run_at_once({import, import});
    const int ok = (r[0].status == 0 ? 1 : 0) + (r[1].status == 0 ? 1 : 0);
    EXPECT_EQ(ok, 1) << r[0].output << "\n" << r[1].output;
    const Result& refused = r[0].status == 0 ? r[1] : r[0];
    EXPECT_EQ(refused.status, 2) << refused.output;
    EXPECT_NE(refused.output.find("already imported"), std::string::npos) << refused.output;
    EXPECT_EQ(Store::open(m_db, OpenMode::ReadOnly).load_scene().sources.size(), 1u);
}

// Another connection's open read keeps the bake from committing past the busy timeout: the
// bake fails (exit 1) saying so, the database is as it was, and the computed bake is kept
// with its scene in `room.unstored-PID.visdb` beside it.
TEST_F(Concurrency, ABakeThatCannotCommitIsKeptBesideTheDatabase) {
    ASSERT_EQ(run("import " + model() + " --db " + m_db).status, 0);
    const std::size_t surfaces = Store::open(m_db, OpenMode::ReadOnly).load_scene().surfaces.size();
    const std::string before = file_bytes(m_db);

    sqlite3* reader = nullptr;
    ASSERT_EQ(sqlite3_open(m_db.c_str(), &reader), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(reader, "BEGIN; SELECT count(*) FROM bakes;", nullptr, nullptr, nullptr),
              SQLITE_OK);
    const Result r = run("bake --bounces 0 --dm off --db " + m_db);
    ASSERT_EQ(sqlite3_exec(reader, "COMMIT", nullptr, nullptr, nullptr), SQLITE_OK);
    sqlite3_close(reader);

    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find(m_db + ": "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("locked"), std::string::npos) << r.output;
    EXPECT_EQ(file_bytes(m_db), before);
    EXPECT_TRUE(Store::open(m_db, OpenMode::ReadOnly).list_bakes().empty());

    std::vector<fs::path> kept;
    for (const fs::directory_entry& e : fs::directory_iterator(m_dir.path()))
        if (e.path().filename().string().rfind("room.unstored-", 0) == 0) kept.push_back(e.path());
    ASSERT_EQ(kept.size(), 1u) << r.output;
    EXPECT_NE(r.output.find("kept"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(kept.front().string()), std::string::npos) << r.output;
    const Store side = Store::open(kept.front().string(), OpenMode::ReadOnly);
    EXPECT_EQ(side.load_scene().surfaces.size(), surfaces);
    ASSERT_EQ(side.list_bakes().size(), 1u);
    EXPECT_EQ(side.load_bake().name, "bake-1");
    EXPECT_GT(side.load_bake().mesh.triangles.size(), 0u);
}

// Runs abrad without the privilege to write files it does not own: as `nobody` when the
// tests run as root (root writes read-only files), else as the user.
Result run_unprivileged(const std::string& args) {
    const std::string prefix =
        geteuid() == 0 ? "setpriv --reuid=65534 --regid=65534 --clear-groups " : "";
    return run_at_once({prefix + abrad(args)}).front();
}

// A database abrad may not write (the file read-only, or its folder, where SQLite needs its
// journal) is refused before the bake and before an import: the scene has no lights and the
// model is broken, which the bake and the import would refuse as bad input (2), so exit
// status 1 shows the check came first.
TEST_F(Concurrency, AReadOnlyDatabaseIsRefusedBeforeAnyWork) {
    const std::string dark =
        m_dir.write("dark.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    ASSERT_EQ(run("import " + dark + " --db " + m_db).status, 0);
    ASSERT_EQ(run("bake --db " + m_db).status, 2);  // no lights: bad input, when writable
    const std::string broken = m_dir.write("broken.obj", "v 0 0 0\nf 1 2 3\n");
    ASSERT_EQ(run("import " + broken + " --db " + m_db).status, 2);  // indices out of range
    if (geteuid() == 0 && system("setpriv --reuid=65534 --regid=65534 --clear-groups true") != 0)
        GTEST_SKIP() << "running as root without setpriv to drop privileges";
    const std::string before = file_bytes(m_db);
    const fs::path dir = m_dir.path();
    const fs::perms read_only =
        fs::perms::owner_read | fs::perms::group_read | fs::perms::others_read;
    const fs::perms read_only_dir =
        read_only | fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec;
    const struct {
        const char* what;
        fs::perms dir_perms, file_perms;
        std::string message;
    } cases[] = {
        {"read-only file", fs::perms::all, read_only, ": the database file is read-only"},
        {"read-only folder", read_only_dir, fs::perms::all,
         ": its directory " + dir.string() + " is not writable"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.what);
        fs::permissions(dir, c.dir_perms);
        fs::permissions(m_db, c.file_perms);
        const Result r = run_unprivileged("bake --db " + m_db);
        // An import is refused before its model is read (this one is broken: bad input)
        const Result import = run_unprivileged("import " + broken + " --db " + m_db);
        fs::permissions(dir, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                 fs::perms::others_read | fs::perms::others_exec);
        fs::permissions(m_db, fs::perms::owner_read | fs::perms::owner_write |
                                  fs::perms::group_read | fs::perms::others_read);
        EXPECT_EQ(r.status, 1) << r.output;
        EXPECT_NE(r.output.find(m_db + c.message), std::string::npos) << r.output;
        EXPECT_EQ(import.status, 1) << import.output;
        EXPECT_NE(import.output.find(m_db + c.message), std::string::npos) << import.output;
        EXPECT_EQ(file_bytes(m_db), before);
    }
}

}  // namespace
