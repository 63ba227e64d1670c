// The readers' child process (issue 19): a crash, a hang, a runaway allocation or an exception
// in the child becomes ChildFailed in the parent, which lives on; the hostile files of the
// report (deep glTF and FBX nesting, a GLB chunk claiming 2 GiB, Collada fractional indices,
// an IFC entity pointing at nothing, 100,000 dotted TOML keys) end as an ImportError naming
// the file.

#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <string>
#include <vector>

#include "abrad/convert/scene_file.h"
#include "child_process.h"
#include "hostile_files.h"
#include "raw_model.h"
#include "shared_data.h"
#include "temp_dir.h"

namespace abrad::convert::detail {
namespace {

namespace fs = std::filesystem;
using ::abrad::testing::TempDir;

/// The message of the ChildFailed `work` ends in (a failure when it returns).
std::string child_failure(const std::function<std::string()>& work,
                          const ChildLimits& limits = kReaderLimits) {
    try {
        const std::string result = run_in_child(work, limits);
        ADD_FAILURE() << "the child returned '" << result << "'";
    } catch (const ChildFailed& e) {
        return e.what();
    }
    return "";
}

TEST(ChildProcess, ReturnsWhatTheWorkReturns) {
    const std::string big(3 << 20, 'x');  // more than a pipe holds at once
    EXPECT_EQ(run_in_child([] { return std::string("a\0b", 3); }), std::string("a\0b", 3));
    EXPECT_EQ(run_in_child([&] { return big; }), big);
    EXPECT_EQ(run_in_child([] { return std::string(); }), "");
}

TEST(ChildProcess, ACrashIsNamedByItsSignal) {
    const std::string what = child_failure([]() -> std::string {
        std::raise(SIGSEGV);
        return "alive";
    });
    EXPECT_NE(what.find("signal 11"), std::string::npos) << what;
    const std::string aborted = child_failure([]() -> std::string { std::abort(); });
    EXPECT_NE(aborted.find("signal 6"), std::string::npos) << aborted;
}

TEST(ChildProcess, AnExceptionKeepsItsMessage) {
    EXPECT_EQ(child_failure([]() -> std::string { throw std::runtime_error("bad chunk"); }),
              "bad chunk");
}

TEST(ChildProcess, ALoopEndsAtTheCpuLimit) {
    ChildLimits limits;
    limits.cpu_seconds = 1.0;
    const std::string what = child_failure(
        []() -> std::string {
            volatile unsigned long spins = 0;
            for (;;) spins = spins + 1U;
        },
        limits);
    EXPECT_NE(what.find("time limit"), std::string::npos) << what;
}

TEST(ChildProcess, ABlockedChildEndsAtTheWallLimit) {
    ChildLimits limits;
    limits.wall_seconds = 0.5;
    const std::string what = child_failure(
        []() -> std::string {
            ::pause();  // no CPU: only the parent's clock ends it
            return "woken";
        },
        limits);
    EXPECT_NE(what.find("time limit: no result after 0.5 s"), std::string::npos) << what;
}

TEST(ChildProcess, AnAllocationPastTheMemoryLimitIsOutOfMemory) {
#if defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "no address-space limit under AddressSanitizer";
#endif
    ChildLimits limits;
    limits.memory_bytes = std::uint64_t{256} << 20;
    const std::string what = child_failure(
        [] {
            std::vector<char> v(std::size_t{1} << 30, 'x');
            return std::string(v.begin(), v.begin() + 1);
        },
        limits);
    EXPECT_EQ(what, "out of memory: more than 256 MiB");
}

// ---------------------------------------------------------------------------------------------
// The report's hostile files through the Assimp reader

/// The message of the ImportError read_assimp throws on `path` (a failure when none).
std::string import_error(const fs::path& path) {
    std::vector<std::string> notes;
    try {
        (void)read_assimp(path, {}, notes);
        ADD_FAILURE() << path << ": read without an error";
    } catch (const ImportError& e) {
        EXPECT_EQ(e.file(), path.string());
        return e.what();
    }
    return "";
}

TEST(HostileAssimpInput, DeepGltfNestingFailsTheReaderNotTheProcess) {
    TempDir dir("isolation");
    const fs::path p = dir.write("deep.gltf", abrad::testing::deep_gltf());
    const std::string what = import_error(p);
    EXPECT_EQ(what.rfind(p.string() + ": the glTF reader failed (", 0), 0U) << what;
}

TEST(HostileAssimpInput, DeepFbxNestingFailsTheReaderNotTheProcess) {
    TempDir dir("isolation");
    const fs::path p = dir.write("deep.fbx", abrad::testing::deep_fbx());
    const std::string what = import_error(p);
    EXPECT_EQ(what.rfind(p.string() + ": the FBX reader failed (", 0), 0U) << what;
}

TEST(HostileAssimpInput, GlbChunkLengthPastTheEndIsRefusedBeforeAssimp) {
    TempDir dir("isolation");
    const std::string glb = abrad::testing::glb_with_chunk_length();
    const fs::path p = dir.write("chunk.glb", glb);
    EXPECT_EQ(import_error(p), p.string() +
                                   ": GLB byte 12: chunk 0 claims 2147483648 bytes, but only " +
                                   std::to_string(glb.size() - 20) + " follow");
}

TEST(HostileAssimpInput, ColladaFractionalIndicesAreRefusedAtTheirLine) {
    TempDir dir("isolation");
    const std::string dae = abrad::testing::collada_fractional_indices();
    const fs::path p = dir.write("fractional.dae", dae);
    EXPECT_EQ(import_error(p), p.string() + ":" +
                                   std::to_string(abrad::testing::line_of(dae, "<p>0.5")) +
                                   ": Collada <p> holds '.5 1.5 2.5': indices and counts are "
                                   "whole numbers");
    std::string counted = dae;
    counted.replace(counted.find("<p>0.5 1.5 2.5"), 14, "<p>0 1 2");
    counted.replace(counted.find("count=\"9\""), 9, "count=\"999999999999\"");
    const fs::path c = dir.write("count.dae", counted);
    EXPECT_EQ(import_error(c), c.string() + ":" +
                                   std::to_string(abrad::testing::line_of(counted, "count=\"9")) +
                                   ": Collada count=\"999999999999\" is more than the file could "
                                   "hold (" +
                                   std::to_string(counted.size()) + " bytes)");
}

TEST(HostileAssimpInput, IfcEntityPointingAtNothingEndsInAnError) {
    ABRAD_REQUIRE_SHARED_DATA("ifc/AC14-FZK-Haus.ifc");
    TempDir dir("isolation");
    const std::string ifc =
        abrad::testing::file_bytes(abrad::testing::shared_data("ifc/AC14-FZK-Haus.ifc"));
    const std::string broken = abrad::testing::ifc_without_a_point(ifc);
    ASSERT_LT(broken.size(), ifc.size());
    const fs::path p = dir.write("dangling.ifc", broken);
    const std::string what = import_error(p);
    EXPECT_EQ(what.rfind(p.string() + ": the IFC reader failed (signal 11", 0), 0U) << what;
}

TEST(HostileSceneFile, ManyDottedKeysFailTheTomlReaderNotTheProcess) {
    TempDir dir("isolation");
    std::string header = "[a";
    for (int i = 0; i < 100000; ++i) header += ".a";
    const fs::path p = dir.write("deep.toml", header + "]\nx = 1\n");
    try {
        (void)read_scene_file(p);
        ADD_FAILURE() << "read without an error";
    } catch (const ImportError& e) {
        EXPECT_EQ(e.file(), p.string());
    }
}

}  // namespace
}  // namespace abrad::convert::detail
