// A reader in a child process: fork, limits, the result through a pipe, and what a child that
// did not finish becomes (issue 19; docs/design.md#bad-input).

#include "child_process.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <new>
#include <system_error>

#if defined(__SANITIZE_ADDRESS__)
#define ABRAD_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define ABRAD_ADDRESS_SANITIZER 1
#endif
#endif

#ifdef ABRAD_ADDRESS_SANITIZER
#include <sanitizer/common_interface_defs.h>
#endif

namespace abrad::convert::detail {

namespace {

/// Lowers the soft limit of `resource` to `value` (never above the hard limit); the hard
/// limit to `hard` when given.
void lower_limit(int resource, rlim_t value, rlim_t hard = RLIM_INFINITY) {
    rlimit r{};
    if (::getrlimit(resource, &r) != 0) return;
    if (hard != RLIM_INFINITY && (r.rlim_max == RLIM_INFINITY || hard < r.rlim_max))
        r.rlim_max = hard;
    if (r.rlim_max != RLIM_INFINITY && value > r.rlim_max) value = r.rlim_max;
    if (r.rlim_cur == RLIM_INFINITY || value < r.rlim_cur) r.rlim_cur = value;
    (void)::setrlimit(resource, &r);
}

bool write_all(int fd, const char* data, std::size_t size) {
    while (size > 0) {
        const ssize_t n = ::write(fd, data, size);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        data += n;
        size -= static_cast<std::size_t>(n);
    }
    return true;
}

/// The child's whole life: limits, the work, its result or exception on `fd`, _exit.
[[noreturn]] void child_main(int fd, const std::function<std::string()>& work,
                             const ChildLimits& limits) {
    // A crash is reported by its signal, not by a sanitizer's or the caller's handler; no core
    for (const int s : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) (void)std::signal(s, SIG_DFL);
#ifdef ABRAD_ADDRESS_SANITIZER
    // Nor by the caller's sanitizer death callback: under AddressSanitizer (no RLIMIT_AS) a
    // reader's runaway allocation (Assimp's 3DS reader asks for 41 GB on a fuzzed count) dies in
    // ASan's allocator, and libFuzzer's callback, inherited by the fork, took that for a crash
    // of its own; the parent reports the child's exit status instead
    __sanitizer_set_death_callback(nullptr);
#endif
    (void)std::signal(SIGPIPE, SIG_IGN);
    lower_limit(RLIMIT_CORE, 0);
    const auto cpu = static_cast<rlim_t>(std::ceil(limits.cpu_seconds));
    lower_limit(RLIMIT_CPU, cpu, cpu + 5);  // SIGXCPU, then SIGKILL 5 s later
    lower_limit(RLIMIT_STACK, static_cast<rlim_t>(limits.stack_bytes));
#ifndef ABRAD_ADDRESS_SANITIZER
    lower_limit(RLIMIT_AS, static_cast<rlim_t>(limits.memory_bytes));
#endif
    char kind = 'R';
    std::string payload;
    try {
        payload = work();
    } catch (const std::bad_alloc&) {
        kind = 'M';
        payload.clear();
    } catch (const std::exception& e) {
        kind = 'E';
        payload = e.what();
    } catch (...) {
        kind = '?';
        payload = "an exception that is not a std::exception";
    }
    const bool sent = write_all(fd, &kind, 1) && write_all(fd, payload.data(), payload.size());
    ::_exit(sent ? 0 : 3);  // no destructors, no atexit handlers (they are the parent's)
}

std::string megabytes(std::uint64_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

/// `s` for a message: "600", "0.5".
std::string seconds(double s) {
    std::string text = std::to_string(s);
    text.erase(text.find_last_not_of('0') + 1);
    if (text.back() == '.') text.pop_back();
    return text;
}

/// "signal 11, segmentation fault: ..." for a child killed by `sig`.
std::string signal_reason(int sig, const ChildLimits& limits) {
    if (sig == SIGXCPU) return "time limit: more than " + seconds(limits.cpu_seconds) + " s of CPU";
    std::string reason = "signal " + std::to_string(sig);
    if (const char* name = ::strsignal(sig)) reason += std::string(", ") + name;
    if (sig == SIGSEGV) {
        reason += ": a crash inside the reader, or its stack (" + megabytes(limits.stack_bytes) +
                  ") overflowed";
    }
    if (sig == SIGKILL) reason += ": killed from outside (out of memory?)";
    return reason;
}

}  // namespace

std::string run_in_child(const std::function<std::string()>& work, const ChildLimits& limits) {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0)
        throw std::system_error(errno, std::generic_category(), "cannot create a pipe");
    const pid_t pid = ::fork();
    if (pid < 0) {
        const int error = errno;
        ::close(fds[0]);
        ::close(fds[1]);
        throw std::system_error(error, std::generic_category(),
                                "cannot start a process for the reader");
    }
    if (pid == 0) {
        ::close(fds[0]);
        child_main(fds[1], work, limits);
    }
    ::close(fds[1]);

    // Read everything the child sends, until it closes the pipe or the wall-time limit
    const auto wall = std::chrono::duration<double>(limits.wall_seconds);
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::nanoseconds>(wall);
    std::string received;
    bool timed_out = false;
    char buffer[1 << 16];
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) {
            timed_out = true;
            break;
        }
        pollfd p{fds[0], POLLIN, 0};
        const int ready = ::poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
        if (ready < 0 && errno != EINTR) break;
        if (ready <= 0) continue;
        const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        received.append(buffer, static_cast<std::size_t>(n));
    }
    ::close(fds[0]);
    if (timed_out) (void)::kill(pid, SIGKILL);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0) {
        if (errno != EINTR) throw ChildFailed("its process was lost");
    }

    // What became of it
    if (timed_out) {
        throw ChildFailed("time limit: no result after " + seconds(limits.wall_seconds) + " s");
    }
    if (WIFSIGNALED(status)) throw ChildFailed(signal_reason(WTERMSIG(status), limits));
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || received.empty()) {
        throw ChildFailed("it stopped with exit status " +
                          std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) +
                          " before giving a result");
    }
    const char kind = received.front();
    received.erase(0, 1);
    if (kind == 'R') return received;
    if (kind == 'M') {
#ifdef ABRAD_ADDRESS_SANITIZER
        throw ChildFailed("out of memory");
#else
        throw ChildFailed("out of memory: more than " + megabytes(limits.memory_bytes));
#endif
    }
    throw ChildFailed(received);  // 'E': the exception's message
}

}  // namespace abrad::convert::detail
