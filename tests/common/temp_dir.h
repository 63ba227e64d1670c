#pragma once
// A scratch directory for one test, shared by every test binary.
//
// The name is unique even when CTest runs many test processes at once and when a process makes
// several: <system temp>/abrad_<prefix>_<pid>_<counter>_<Suite>.<Test>. The directory is
// created empty and removed with its files when the test that made it passed; when the test
// failed it is kept (its path is printed) so the files can be looked at.

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <system_error>

namespace abrad::testing {

/// The bytes of the file at `p` (empty when it cannot be read).
inline std::string file_bytes(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

class TempDir {
  public:
    /// `prefix` names the test binary or module in the directory name (letters, digits, _).
    explicit TempDir(const std::string& prefix = "test") {
        static std::atomic<unsigned> counter{0};
        std::string test = "no_test";
        if (const auto* info = ::testing::UnitTest::GetInstance()->current_test_info())
            test = std::string(info->test_suite_name()) + "." + info->name();
        for (char& c : test)  // parameterised names hold '/'
            if (c == '/') c = '_';
        m_path = std::filesystem::temp_directory_path() /
                 ("abrad_" + prefix + "_" + std::to_string(::getpid()) + "_" +
                  std::to_string(counter++) + "_" + test);
        std::filesystem::remove_all(m_path);  // a leftover of an earlier process with this pid
        std::filesystem::create_directories(m_path);
    }
    ~TempDir() {
        if (::testing::Test::HasFailure()) {
            std::cerr << "test failed: its files are kept in " << m_path.string() << "\n";
            return;
        }
        std::error_code ec;
        std::filesystem::remove_all(m_path, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    const std::filesystem::path& path() const { return m_path; }
    /// The path of `name` in this directory.
    std::filesystem::path operator/(const std::string& name) const { return m_path / name; }
    /// The same as a string (for command lines and APIs taking strings).
    std::string file(const std::string& name) const { return (m_path / name).string(); }

    /// Writes `bytes` byte for byte to `name` in this directory and returns its path.
    std::filesystem::path write(const std::string& name, const std::string& bytes) const {
        const std::filesystem::path p = m_path / name;
        std::ofstream out(p, std::ios::binary);
        out << bytes;
        return p;
    }

    /// How many files and folders the directory holds (not recursive).
    std::size_t entry_count() const {
        return static_cast<std::size_t>(std::distance(std::filesystem::directory_iterator(m_path),
                                                      std::filesystem::directory_iterator{}));
    }

  private:
    std::filesystem::path m_path;
};

}  // namespace abrad::testing
