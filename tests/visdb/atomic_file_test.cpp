// The shared atomic output file (abrad/atomic_file.h): a file appears whole or not at all, a
// failed write names the path and leaves the old file byte for byte, and no temporary stays.

#include "abrad/atomic_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "file_size_limit.h"
#include "temp_dir.h"

namespace fs = std::filesystem;
using abrad::testing::file_bytes;
using abrad::testing::TempDir;

namespace {

// The message of the OutputError `write` throws ("" when it throws none).
template <typename Write>
std::string error_of(Write write) {
    try {
        write();
    } catch (const abrad::OutputError& e) {
        return e.what();
    }
    return {};
}

TEST(AtomicFile, WritesAndReplacesLeavingOnlyTheFile) {
    const TempDir dir("atomic");
    const fs::path path = dir / "table.csv";
    abrad::write_file_atomically(path, "a,b\n1,2\n");
    EXPECT_EQ(file_bytes(path), "a,b\n1,2\n");
    abrad::write_file_atomically(path, "a,b\n3,4\n");
    EXPECT_EQ(file_bytes(path), "a,b\n3,4\n");
    EXPECT_EQ(dir.entry_count(), 1u);
}

TEST(AtomicFile, NothingAppearsBeforeCommitNorWithoutIt) {
    const TempDir dir("atomic");
    const fs::path path = dir / "out.txt";
    {
        abrad::AtomicFile file(path);
        file.write("half of it");
        file.close();
        EXPECT_FALSE(fs::exists(path));
    }  // destroyed without commit
    EXPECT_FALSE(fs::exists(path));
    EXPECT_EQ(dir.entry_count(), 0u);
}

TEST(AtomicFile, AFullDiskNamesThePathAndKeepsTheOldFile) {
    const TempDir dir("atomic");
    const fs::path path = dir / "values.csv";
    const std::string old = "the old file\n";
    abrad::write_file_atomically(path, old);
    const std::string big(std::size_t{64} * 1024, 'x');
    std::string message;
    {
        const abrad::testing::FileSizeLimit full(4096);
        message = error_of([&] { abrad::write_file_atomically(path, big); });
    }
    EXPECT_EQ(message, path.string() + ": cannot write: File too large");
    EXPECT_EQ(file_bytes(path), old);
    EXPECT_EQ(dir.entry_count(), 1u);  // no temporary left
}

TEST(AtomicFile, AMissingDirectoryNamesThePath) {
    const TempDir dir("atomic");
    const fs::path path = dir / "no" / "such" / "dir" / "x.csv";
    const std::string message = error_of([&] { abrad::write_file_atomically(path, "x"); });
    EXPECT_EQ(message.rfind(path.string() + ": cannot write: ", 0), 0u) << message;
    EXPECT_FALSE(fs::exists(path));
}

TEST(AtomicFile, ARenameOntoADirectoryFailsAndRemovesTheTemporary) {
    const TempDir dir("atomic");
    const fs::path path = dir / "taken";
    fs::create_directories(path / "inside");
    const std::string message = error_of([&] { abrad::write_file_atomically(path, "x"); });
    EXPECT_EQ(message.rfind(path.string() + ": cannot write: ", 0), 0u) << message;
    EXPECT_TRUE(fs::is_directory(path / "inside"));
    EXPECT_EQ(dir.entry_count(), 1u);
}

TEST(AtomicFile, TemporariesOfOneProcessHaveDistinctNames) {
    const TempDir dir("atomic");
    const fs::path path = dir / "same.txt";
    // Two open at once for the same path: both complete, the later commit wins
    abrad::AtomicFile first(path);
    abrad::AtomicFile second(path);
    first.write("first");
    second.write("second");
    first.close();
    second.close();
    first.commit();
    second.commit();
    EXPECT_EQ(file_bytes(path), "second");
    EXPECT_EQ(dir.entry_count(), 1u);
}

}  // namespace
