#pragma once
// One fuzz target per reader (issue 19; docs/fuzzing.md). A target file defines its body with
//
//     ABRAD_FUZZ_TARGET(obj) { ... use data, size ... return 0; }
//
// Built for libFuzzer (ABRAD_FUZZ=ON, clang), each target is its own binary whose
// LLVMFuzzerTestOneInput is that body. Built for the corpus replay (the normal test build),
// every target is in one binary, registered by name, and fuzz_replay.cpp runs each corpus
// folder's files through the target of the folder's name.
//
// A target returns normally on input the reader refuses (its error is the expected outcome);
// anything else (a crash, a sanitizer report, an exception of another type) is a finding.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>

namespace abrad::fuzz {

using Target = int (*)(const std::uint8_t* data, std::size_t size);

/// The targets of the replay binary by name (filled before main by ABRAD_FUZZ_TARGET).
inline std::map<std::string, Target>& targets() {
    static std::map<std::string, Target> all;
    return all;
}

inline bool add_target(const char* name, Target target) {
    targets().emplace(name, target);
    return true;
}

/// `data` written to `name` in a scratch folder of this process (the readers take paths);
/// returns the path.
std::filesystem::path write_input(const std::string& name, std::string_view data);

/// The input as text.
inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
    return {reinterpret_cast<const char*>(data), size};
}

}  // namespace abrad::fuzz

#ifdef ABRAD_FUZZ_LIBFUZZER
#define ABRAD_FUZZ_TARGET(name) \
    extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
#else
#define ABRAD_FUZZ_TARGET(name)                                         \
    static int fuzz_##name(const std::uint8_t* data, std::size_t size); \
    [[maybe_unused]] static const bool kAdded_##name =                  \
        ::abrad::fuzz::add_target(#name, fuzz_##name);                  \
    static int fuzz_##name(const std::uint8_t* data, std::size_t size)
#endif
