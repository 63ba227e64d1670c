// abrad: the command line, a table of subcommands. Each lives in tools/src/cmd_<name>.cpp
// (its options and its run function); what several share is in tools/src/cli_common.h.
//
// Exit status: 0 success; 1 failure (I/O, a full disk, a database locked by another writer,
// internal errors); 2 bad input or usage (a malformed model or database, an unknown option, an
// option the chosen format does not use, a scene that cannot be baked). Errors go to stderr as
// "abrad <cmd>: <file>:<line>: <message>".

#include <CLI/CLI.hpp>
#include <iostream>
#include <string>
#include <string_view>

#include "abrad/export/writers.h"
#include "abrad/radiosity/cluster.h"
#include "abrad/visdb/store.h"
#include "src/cli_common.h"

namespace abrad::tools::cli {
namespace {

// The subcommands, in the order of `abrad --help`.
constexpr Command kCommands[] = {
    {"import", "Import model files into a visual database", add_import, run_import},
    {"bake", "Bake the database's scene: direct light, and interreflection with --bounces",
     add_bake, run_bake},
    {"export",
     "Export a bake as shaded PLY, OBJ, glTF or a POV-Ray scene, or the model as a POV-Ray "
     "reference scene (the output's extension picks the format unless --format is given)",
     add_export, run_export},
    {"render",
     "Render a bake with abrad's Gouraud rasterizer (PNG tone-mapped, EXR linear), or "
     "false-colour irradiance",
     add_render, run_render},
    {"compare",
     "Compare two images in linear light (RMSE, PSNR, max error); exit 1 past a threshold",
     add_compare, run_compare},
    {"info", "List what a visual database holds", add_info, run_info},
    {"probe",
     "Irradiance at points from a CSV file: exact direct light plus the indirect part gathered "
     "from a bake",
     add_probe, run_probe},
    {"simplify",
     "Store a light mesh of a bake: OpenMesh decimation within a relative irradiance bound",
     add_simplify, run_simplify},
    {"field-error", "Gouraud-interpolated irradiance of a bake against the exact direct irradiance",
     add_field_error, run_field_error},
    {"report",
     "Write an HTML report of a bake (grids with isolux plans, luminaires, energy balance, a 3D "
     "view) into a folder that opens offline",
     add_report, run_report},
    {"run", "Import, bake and export in one go", add_run, run_run},
    {"generate",
     "Generate a building floor (rooms, doors, furniture, ceiling lights) into a visual "
     "database",
     add_generate, run_generate},
    {"bench", "Speed against error over a grid of bake settings, and scaling on generated floors",
     add_bench, run_bench},
};

// Runs the parsed subcommand, mapping every error to its message and exit status.
int run_command(const Command& command, const Invocation& call) {
    try {
        // Only bake shares its work over MPI ranks; the others would run once per rank
        if (radiosity::Cluster::launched_as_ranks() && std::string_view(command.name) != "bake")
            bad_input(std::string("only abrad bake runs as several MPI ranks: run ") +
                      command.name + " once, without mpirun or srun");
        return command.run(call);
    } catch (...) {
        return report_failure(command.name, "", std::current_exception());
    }
}

int run_cli(int argc, char** argv) {
    CLI::App app{"abrad: lighting bakes for buildings with an A-buffer hemicube radiosity"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "abrad 0.1.0");
    app.footer("Exit status: 0 ok, 1 failure, 2 bad input or usage.");
    for (const Command& c : kCommands) c.add_options(*app.add_subcommand(c.name, c.description));
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);
        const auto* sub = app.get_subcommands().empty() ? nullptr : app.get_subcommands().front();
        const std::string name = sub ? " " + sub->get_name() : std::string();
        std::cerr << "abrad" << name << ": " << e.what() << "\n(see abrad" << name << " --help)\n";
        return kExitBadInput;
    }
    const CLI::App& sub = *app.get_subcommands().front();
    for (const Command& c : kCommands)
        if (sub.get_name() == c.name) return run_command(c, {sub, argc, argv});
    return kExitBadInput;  // unreachable: CLI11 accepts only the subcommands above
}

}  // namespace
}  // namespace abrad::tools::cli

int main(int argc, char** argv) {
    try {
        return abrad::tools::cli::run_cli(argc, argv);
    } catch (const std::exception& e) {  // outside any subcommand: CLI11 set-up, reporting
        std::cerr << "abrad: " << e.what() << "\n";
        return abrad::tools::cli::kExitFailure;
    } catch (...) {
        std::cerr << "abrad: unknown error\n";
        return abrad::tools::cli::kExitFailure;
    }
}
