#pragma once
// Third-party readers that cannot be made safe (Assimp, toml++) run in a forked child process
// with stack, memory and CPU-time limits, so that their crash, hang or runaway allocation
// becomes an error message naming the file instead of taking abrad down (issue 19). The child
// sends its result back through a pipe as bytes; ByteWriter and ByteReader are that form.

#include <cstdint>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

namespace abrad::convert::detail {

/// Limits of a reader's child process.
struct ChildLimits {
    /// RLIMIT_CPU (SIGXCPU, then SIGKILL 5 s later).
    double cpu_seconds = 600.0;
    /// Wall time after which the parent kills the child (one blocked without using CPU).
    double wall_seconds = 1210.0;
    /// RLIMIT_AS. Not applied under AddressSanitizer, whose shadow memory takes terabytes of
    /// address space; the readers' own size checks stand alone there.
    std::uint64_t memory_bytes = std::uint64_t{8} << 30;
    /// RLIMIT_STACK (the main thread's stack; a thread's stack is fixed when it starts).
    std::uint64_t stack_bytes = std::uint64_t{16} << 20;
};

/// The limits every reader's child gets (docs/design.md#bad-input).
inline constexpr ChildLimits kReaderLimits{};

/// The child did not finish: what happened, for "the FORMAT reader failed (REASON)".
class ChildFailed : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// Runs `work` in a forked child under `limits` and returns the bytes it returned. Throws
/// ChildFailed when the child throws (its message), runs out of memory, is killed by a signal,
/// exceeds a limit or exits without a result; std::system_error when no child can be started.
std::string run_in_child(const std::function<std::string()>& work,
                         const ChildLimits& limits = kReaderLimits);

/// Appends plain values and strings to a byte string.
class ByteWriter {
  public:
    template <typename T>
    void put(const T& value) {
        static_assert(std::is_trivially_copyable_v<T>);
        m_bytes.append(reinterpret_cast<const char*>(&value), sizeof(T));
    }
    void put_string(std::string_view s) {
        put<std::uint64_t>(s.size());
        m_bytes.append(s);
    }
    std::string& bytes() { return m_bytes; }

  private:
    std::string m_bytes;
};

/// Reads what ByteWriter wrote; throws ChildFailed when the bytes run out (a result cut
/// short).
class ByteReader {
  public:
    explicit ByteReader(std::string_view bytes) : m_bytes(bytes) {}
    template <typename T>
    T get() {
        static_assert(std::is_trivially_copyable_v<T>);
        T value;
        std::memcpy(&value, take(sizeof(T)).data(), sizeof(T));
        return value;
    }
    std::string get_string() { return std::string(take(get<std::uint64_t>())); }
    /// A count of items of at least `item_bytes` each, checked against the bytes left.
    std::size_t get_count(std::size_t item_bytes) {
        const auto n = get<std::uint64_t>();
        if (item_bytes > 0 && n > (m_bytes.size() - m_at) / item_bytes) cut_short();
        return static_cast<std::size_t>(n);
    }
    bool at_end() const { return m_at == m_bytes.size(); }

  private:
    std::string_view take(std::uint64_t n) {
        if (n > m_bytes.size() - m_at) cut_short();
        const std::string_view s = m_bytes.substr(m_at, n);
        m_at += n;
        return s;
    }
    [[noreturn]] static void cut_short() { throw ChildFailed("its result was cut short"); }
    std::string_view m_bytes;
    std::size_t m_at = 0;
};

}  // namespace abrad::convert::detail

namespace abrad::convert::detail {

/// Parses `bytes` as TOML in a child process and throws ImportError naming `file` when that
/// parse crashes or does not finish (toml++ recurses once per dotted key and nesting level:
/// a table header of 100,000 dotted keys overflowed its stack). A parse error is not thrown
/// here: the caller's own parse, safe after this, reports it with its line.
void check_toml_in_child(std::string_view bytes, const std::string& file);

}  // namespace abrad::convert::detail
