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

#ifdef ABRAD_SAMPLES
/// Imports the paper room sample into a new database `db` and bakes it with `bake_options`:
/// the result of the first command that failed, else the bake's.
inline Result import_and_bake_paper_room(const std::string& db, const std::string& bake_options) {
    const Result imported = run_abrad("import " + std::string(ABRAD_SAMPLES) +
                                      "/paper_simple/paper_occluder.obj --db " + db);
    if (imported.status != 0) return imported;
    return run_abrad("bake " + bake_options + " --db " + db);
}
#endif

}  // namespace abrad::testing
