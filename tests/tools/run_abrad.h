#pragma once
// Runs the abrad executable under test and captures its status and output (stdout + stderr).

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace abrad::testing {

struct Result {
    int status;
    std::string output;  // stdout and stderr
};

inline Result run_abrad(const std::string& args) {
    const std::string cmd = std::string(ABRAD_EXE) + " " + args + " 2>&1";
    FILE* pipe = popen(cmd.c_str(), "r");
    if (!pipe) return {-1, "popen failed"};
    std::string out;
    char buf[4096];
    std::size_t n;
    while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, n);
    const int st = pclose(pipe);
    return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

}  // namespace abrad::testing
