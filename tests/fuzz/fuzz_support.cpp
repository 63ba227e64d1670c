// The fuzz targets' scratch folder: one per process, removed at exit.

#include <unistd.h>

#include <fstream>
#include <system_error>

#include "fuzz_target.h"

namespace abrad::fuzz {

namespace {

/// <temp>/abrad_fuzz_<pid>, created on first use and removed when the process ends.
class ScratchFolder {
  public:
    ScratchFolder()
        : m_path(std::filesystem::temp_directory_path() /
                 ("abrad_fuzz_" + std::to_string(::getpid()))) {
        std::filesystem::create_directories(m_path);
    }
    ~ScratchFolder() {
        std::error_code ec;
        std::filesystem::remove_all(m_path, ec);
    }
    ScratchFolder(const ScratchFolder&) = delete;
    ScratchFolder& operator=(const ScratchFolder&) = delete;
    const std::filesystem::path& path() const { return m_path; }

  private:
    std::filesystem::path m_path;
};

}  // namespace

std::filesystem::path write_input(const std::string& name, std::string_view data) {
    static const ScratchFolder folder;
    const std::filesystem::path p = folder.path() / name;
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(data.data(), static_cast<std::streamsize>(data.size()));
    return p;
}

}  // namespace abrad::fuzz
