// Loads the OpenImageIO module on first use: see oiio_module.h.

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "abrad/export/writers.h"
#include "oiio_module.h"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#endif

namespace abrad::exporter::oiio {

namespace {

namespace fs = std::filesystem;

constexpr const char* kModuleName = "libabrad_oiio.so";

std::vector<fs::path> candidates() {
    // A module named in the environment is the only place looked at
    if (const char* env = std::getenv("ABRAD_OIIO_MODULE"); env != nullptr && *env != '\0')
        return {fs::path(env)};
    std::vector<fs::path> out;
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) out.push_back(exe.parent_path() / kModuleName);
#ifdef ABRAD_OIIO_MODULE_PATH
    out.emplace_back(ABRAD_OIIO_MODULE_PATH);
#endif
    return out;
}

const Api* load() {
#if defined(__SANITIZE_ADDRESS__)
    // The sanitizer build (CI's): LeakSanitizer's check runs now, once, instead of at exit.
    // GCC 12's LeakSanitizer guesses the bounds of a dynamic TLS block that lands 16 bytes past
    // a page from a header glibc no longer writes; with the module's dependencies loaded, its
    // exit-time scan read such a bogus range and crashed ("Tracer caught signal 11"), depending
    // only on where the blocks landed. Checked now, before they exist, every leak so far is
    // still found, and the exit-time scan does not run.
    __lsan_do_leak_check();
#endif
    std::string tried;
    for (const fs::path& path : candidates()) {
        tried += "\n  " + path.string();
        std::error_code ec;
        if (!fs::is_regular_file(path, ec)) {
            tried += ": no such file";
            continue;
        }
        // Kept loaded for the life of the process (never dlclose'd)
        void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (handle == nullptr) {
            const char* why = dlerror();
            tried += std::string(": ") + (why != nullptr ? why : "cannot be loaded");
            continue;
        }
        using Entry = const Api* (*)();
        // NOLINTNEXTLINE(cppcoreguidelines-pro-type-reinterpret-cast): dlsym's one use
        const auto entry = reinterpret_cast<Entry>(dlsym(handle, "abrad_oiio_api"));
        const Api* table = entry != nullptr ? entry() : nullptr;
        if (table == nullptr || table->abi != kAbi || table->size != sizeof(Api)) {
            tried += ": not this build's module (rebuild abrad)";
            continue;
        }
        return table;
    }
    throw ExportError(std::string("image support: cannot load ") + kModuleName +
                      " (OpenImageIO); looked at:" + tried +
                      "\n(set ABRAD_OIIO_MODULE to its path, or keep it beside the abrad binary)");
}

}  // namespace

const Api& api() {
    static const Api* const table = load();  // a failed load throws and is tried again next time
    return *table;
}

}  // namespace abrad::exporter::oiio
