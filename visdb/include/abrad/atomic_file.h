#pragma once
// Output files that appear whole or not at all, for every writer of abrad (exports, images,
// CSV files, the benchmark's tables).
//
// BasicAtomicFile<Error> writes to a temporary in the target's directory and renames it over
// the target only after every write, the flush, fsync and close succeeded. Any failure throws
// Error("PATH: cannot write: <reason>") (e.g. "No space left on device", "File too large"),
// removes the temporary and leaves an existing file at PATH byte for byte as it was.
//
// The temporary: on Linux an unnamed file (O_TMPFILE) that gets the name
// `PATH.tmp-<pid>-<n>` only when it is complete, just before the rename, so a process killed
// while writing leaves nothing behind; where the file system has no O_TMPFILE (or /proc is not
// mounted), that name from the start (a kill then leaves it behind; the pid and counter keep
// concurrent writers apart).

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>

namespace abrad {

/// An output file that could not be written; `what()` is "PATH: cannot write: <reason>".
class OutputError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// `PATH.tmp-<pid>-<n>`: a temporary's name beside `path`, unique among the temporaries of
/// every process writing `path` (also the store's, for a database being created).
inline std::string temporary_name(const std::filesystem::path& path) {
    static std::atomic<unsigned> counter{0};  // only makes names unique within the process
    return path.string() + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

/// A file written to a temporary beside `PATH` and renamed to `PATH` by commit(). Destroying
/// it without a successful commit() removes the temporary. Errors throw `Error` (constructible
/// from a string) as "PATH: cannot write: <strerror>". Not copyable.
template <typename Error>
class BasicAtomicFile {
  public:
    /// Opens the temporary in `path`'s directory (the current one for a bare name).
    explicit BasicAtomicFile(std::filesystem::path path) : m_path(std::move(path)) {
        const std::filesystem::path dir =
            m_path.has_parent_path() ? m_path.parent_path() : std::filesystem::path(".");
        // Create an unnamed temporary (it is named through /proc/self/fd), or a named one where
        // O_TMPFILE or /proc is missing
        int fd = -1;
        errno = EOPNOTSUPP;
        if (::access("/proc/self/fd", X_OK) == 0)
            fd = ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
        if (fd < 0 && (errno == EOPNOTSUPP || errno == EISDIR || errno == EINVAL)) {
            m_tmp = temporary_name(m_path);
            fd = ::open(m_tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
            if (fd < 0) m_tmp.clear();
        }
        if (fd < 0) fail_io(errno);
        m_file = ::fdopen(fd, "wb");
        if (m_file == nullptr) {
            const int err = errno;
            ::close(fd);
            discard();
            fail_io(err);
        }
    }
    BasicAtomicFile(const BasicAtomicFile&) = delete;
    BasicAtomicFile& operator=(const BasicAtomicFile&) = delete;
    ~BasicAtomicFile() { discard(); }

    /// Writes `bytes` (buffered by stdio).
    void write(std::string_view bytes) {
        if (bytes.empty()) return;
        if (m_file == nullptr) fail_io(EBADF);
        errno = 0;
        if (std::fwrite(bytes.data(), 1, bytes.size(), m_file) != bytes.size()) fail_io(errno);
    }

    /// Writes `buffer` once it holds at least `threshold` bytes, then clears it.
    void write_if_full(std::string& buffer, std::size_t threshold = std::size_t{1} << 20) {
        if (buffer.size() >= threshold) {
            write(buffer);
            buffer.clear();
        }
    }

    /// Flushes, syncs and closes the temporary, naming it if it was unnamed: the file is
    /// complete on the disk but not yet at `PATH`.
    void close() {
        if (m_file == nullptr) return;
        // Flush stdio's buffer and the kernel's
        errno = 0;
        if (std::fflush(m_file) != 0) fail_io(errno);
        if (::fsync(::fileno(m_file)) != 0) fail_io(errno);
        // Give an unnamed temporary its name while its descriptor is still open
        if (m_tmp.empty()) {
            const std::string self = "/proc/self/fd/" + std::to_string(::fileno(m_file));
            const std::string name = temporary_name(m_path);
            if (::linkat(AT_FDCWD, self.c_str(), AT_FDCWD, name.c_str(), AT_SYMLINK_FOLLOW) != 0)
                fail_io(errno);
            m_tmp = name;
        }
        errno = 0;
        const bool closed = std::fclose(m_file) == 0;
        m_file = nullptr;
        if (!closed) fail_io(errno);
    }

    /// Closes the temporary and renames it to `PATH`, replacing what was there.
    void commit() {
        close();
        if (m_committed) return;
        if (std::rename(m_tmp.c_str(), m_path.c_str()) != 0) fail_io(errno);
        m_committed = true;
    }

    /// The final path.
    const std::filesystem::path& path() const { return m_path; }

  private:
    // Closes and removes the temporary (nothing after a commit)
    void discard() noexcept {
        if (m_file != nullptr) std::fclose(m_file);
        m_file = nullptr;
        if (!m_committed && !m_tmp.empty()) std::remove(m_tmp.c_str());
        m_tmp.clear();
    }

    [[noreturn]] void fail_io(int err) {
        discard();
        // strerror text, without strerror's shared buffer
        throw Error(
            m_path.string() + ": cannot write: " +
            (err != 0 ? std::generic_category().message(err) : std::string("unknown I/O error")));
    }

    std::filesystem::path m_path;
    std::string m_tmp;  ///< the temporary's name; empty while it is unnamed
    std::FILE* m_file = nullptr;
    bool m_committed = false;
};

/// The atomic file of abrad's own outputs (CSV files, tables): errors are OutputError.
using AtomicFile = BasicAtomicFile<OutputError>;

/// Writes `bytes` to `path` through an AtomicFile: the whole of it or, on failure
/// (OutputError naming `path`), nothing, with an existing file left as it was.
inline void write_file_atomically(const std::filesystem::path& path, std::string_view bytes) {
    AtomicFile file(path);
    file.write(bytes);
    file.commit();
}

}  // namespace abrad
