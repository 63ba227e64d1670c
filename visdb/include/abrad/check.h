#pragma once
// Checking macros for invariants, usable from any namespace (they name abrad::detail fully).
//
//   ABRAD_CHECK(cond, message)   always compiled in. When `cond` is false it throws
//                                std::logic_error("<file>:<line>: check failed: <cond>:
//                                <message>").
//   ABRAD_DCHECK(cond, message)  the same when ABRAD_DCHECKS is defined (CMake option
//                                ABRAD_DCHECK: on in the `test` preset, off in `release`);
//                                otherwise `cond` and `message` are type-checked but never
//                                evaluated, so they may be expensive (a loop over a mesh).
//
// `message` is anything a std::string can be built from (a literal, a std::string, an
// expression such as "surface " + std::to_string(i)); it is evaluated only when the check
// fails.
//
// Why throw rather than abort: abrad's commands catch exceptions at the top, report them on
// stderr with exit status 1 and leave the database as it was (the store writes in one
// transaction), a bake running in a worker thread hands the exception back to the caller, and
// a test can EXPECT_THROW a broken invariant instead of dying. A failed check is a bug in
// abrad, not bad input: hence std::logic_error, not the modules' input errors (ImportError,
// BakeError...), so callers that turn input errors into exit status 2 do not hide it.

#include <stdexcept>
#include <string>

namespace abrad::detail {

[[noreturn]] inline void check_failed(const char* file, int line, const char* condition,
                                      const std::string& message) {
    throw std::logic_error(std::string(file) + ":" + std::to_string(line) +
                           ": check failed: " + condition + ": " + message);
}

}  // namespace abrad::detail

#define ABRAD_CHECK(cond, message)                                                          \
    do {                                                                                    \
        if (!(cond)) [[unlikely]]                                                           \
            ::abrad::detail::check_failed(__FILE__, __LINE__, #cond, std::string(message)); \
    } while (false)

#ifdef ABRAD_DCHECKS
#define ABRAD_DCHECK(cond, message) ABRAD_CHECK(cond, message)
#else
// Never evaluated, but still compiled: a DCHECK cannot rot in release builds.
#define ABRAD_DCHECK(cond, message)                  \
    do {                                             \
        if (false) {                                 \
            static_cast<void>(cond);                 \
            static_cast<void>(std::string(message)); \
        }                                            \
    } while (false)
#endif
