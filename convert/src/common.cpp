// Helpers every importer shares: located messages, whole-file reads, checksums, timestamps.

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>
#include <system_error>

#include "raw_model.h"

namespace abrad::convert::detail {

/// "FILE:LINE: message", or "FILE: message" when `line` is 0.
std::string located(const std::string& file, std::size_t line, std::string_view message) {
    std::string s = file;
    if (line > 0) {
        s += ':';
        s += std::to_string(line);
    }
    s += ": ";
    s += message;
    return s;
}

std::string quote(std::string_view s, std::size_t max) {
    std::string q = "'";
    if (s.size() > max) {
        q += s.substr(0, max);
        q += "...";
    } else {
        q += s;
    }
    q += "'";
    return q;
}

std::string read_file_bytes(const std::filesystem::path& path, const std::string& display,
                            const char* what) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    if (status.type() == std::filesystem::file_type::not_found) {
        throw ImportError(display, 0, "no such " + std::string(what));
    }
    if (ec)
        throw ImportError(display, 0, "cannot access " + std::string(what) + ": " + ec.message());
    if (std::filesystem::is_directory(status)) {
        throw ImportError(display, 0, "is a directory, not a " + std::string(what));
    }
    // A device, FIFO or socket would block or never end (/dev/zero): regular files only
    if (!std::filesystem::is_regular_file(status)) {
        throw ImportError(
            display, 0,
            "is not a regular file (a device, FIFO or socket), not a " + std::string(what));
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) throw ImportError(display, 0, "cannot open " + std::string(what));
    std::ostringstream bytes;
    if (in.peek() != std::ifstream::traits_type::eof()) bytes << in.rdbuf();
    if (in.bad()) throw ImportError(display, 0, "cannot read " + std::string(what));
    return std::move(bytes).str();
}

void check_reference_inside(const std::filesystem::path& ref, const std::filesystem::path& model,
                            const std::string& referrer, std::size_t line, std::string_view what) {
    // Compare the resolved paths (symbolic links followed, "..", "." removed) by component
    std::error_code ec;
    const std::filesystem::path parent = model.parent_path().empty() ? "." : model.parent_path();
    const std::filesystem::path root = std::filesystem::weakly_canonical(parent, ec);
    const std::filesystem::path target =
        ec ? std::filesystem::path() : std::filesystem::weakly_canonical(ref, ec);
    if (!ec && !root.empty() && !target.empty()) {
        const auto [r, t] = std::mismatch(root.begin(), root.end(), target.begin(), target.end());
        if (r == root.end() && t != target.end()) return;
    }
    throw ImportError(referrer, line,
                      std::string(what) + " " + quote(ref.string()) +
                          " is outside the model's folder " + quote(parent.string()) +
                          "; refused (--allow-outside-refs allows it)");
}

std::string fnv1a64_hex(std::string_view bytes) {
    std::uint64_t h = 0xcbf29ce484222325ULL;
    for (const char ch : bytes) {
        h ^= static_cast<std::uint8_t>(ch);
        h *= 0x100000001b3ULL;
    }
    std::array<char, 17> buf{};
    std::snprintf(buf.data(), buf.size(), "%016llx", static_cast<unsigned long long>(h));
    return buf.data();
}

std::string utc_now_iso8601() {
    const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
    std::tm tm{};
    gmtime_r(&t, &tm);
    std::array<char, 32> buf{};
    std::strftime(buf.data(), buf.size(), "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf.data();
}

}  // namespace abrad::convert::detail
