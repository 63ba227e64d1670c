// abrad export: a bake as shaded PLY, OBJ, glTF or an unlit POV-Ray scene, or the model as a
// POV-Ray reference scene. The formats are one table: name, extensions, the options each uses,
// the function that writes it; dispatch and the "not used by this format" errors come from it.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <iostream>
#include <string_view>
#include <vector>

#include "abrad/export/exposure.h"
#include "abrad/export/render.h"
#include "abrad/export/writers.h"
#include "cli_common.h"

namespace fs = std::filesystem;

namespace abrad::tools::cli {
namespace {

// What a format's write function gets: the arguments, the open database and its scene.
struct ExportJob {
    const ExportArgs& args;
    std::string_view format;
    visdb::Store& store;
    const visdb::Scene& scene;
    /// --scene-mix: the mixed bake, and the tone map of the bake's own light scene (so that a
    /// dimmed scene looks dimmer, unless --exposure says otherwise)
    const std::optional<visdb::Bake>& mixed;
    const std::optional<exporter::ToneMap>& own_tone;
};

// The bake to export and its tone map (--exposure, else the bake's own).
struct ToneMapped {
    visdb::Bake bake;
    exporter::ToneMap tone;
};

// --simplify and its options, as the light mesh's options.
const SimplifyOptionNames kSimplifyNames{.error = "--simplify", .prefix = "--simplify-"};
exporter::SimplifyOptions simplify_options(const ExportArgs& a) {
    return {.error = a.simplify.value_or(kExportSimplify.error),
            .floor = a.simplify_floor,
            .refit = a.simplify_refit,
            .budget = a.simplify_budget};
}

ToneMapped bake_of(const ExportJob& job) {
    visdb::Bake b =
        job.mixed ? *job.mixed : load_bake_for(job.store, job.args.db, job.args.bake, "export");
    const exporter::ToneMap tone =
        job.own_tone ? *job.own_tone : exposure_for(b, job.scene, job.args.view);
    // --simplify: a light mesh, toned as the bake itself
    if (job.args.simplify) b.mesh = simplify_mesh(b, simplify_options(job.args), kSimplifyNames);
    return {std::move(b), tone};
}

void report(const ExportJob& job, const ToneMapped& t) {
    std::cout << "wrote " << job.args.output << " (" << job.format << ", bake '" << t.bake.name
              << "', " << t.bake.mesh.positions.size() << " vertices, "
              << t.bake.mesh.triangles.size() << " triangles, exposure " << t.tone.exposure
              << " per " << t.bake.unit << ")\n";
}

// --up, else the format's convention.
exporter::UpAxis up_axis(const ExportArgs& a, exporter::UpAxis convention) {
    if (a.up.empty()) return convention;
    return a.up == "y" ? exporter::UpAxis::Y : exporter::UpAxis::Z;
}

void write_ply(const ExportJob& job) {
    const ToneMapped t = bake_of(job);
    exporter::write_ply(
        job.args.output, t.bake.mesh, t.tone,
        {.ascii = job.args.ascii,
         .comment = "abrad bake " + t.bake.name,
         .up = up_axis(job.args, exporter::UpAxis::Z),
         .positions = job.args.positions == "float" ? exporter::PlyPositions::Float
                                                    : exporter::PlyPositions::Double,
         .surface_ids = job.args.surface_ids == "vertex" ? exporter::PlySurfaceIds::Vertex
                                                         : exporter::PlySurfaceIds::Face});
    report(job, t);
}

void write_obj(const ExportJob& job) {
    const ToneMapped t = bake_of(job);
    exporter::write_obj(job.args.output, job.scene, t.bake.mesh, t.tone,
                        {.up = up_axis(job.args, exporter::UpAxis::Y)});
    report(job, t);
}

void write_gltf(const ExportJob& job) {
    const ToneMapped t = bake_of(job);
    const std::size_t transcoded =
        exporter::write_gltf(job.args.output, job.scene, t.bake.mesh, t.tone);
    report(job, t);
    if (transcoded > 0)
        std::cerr << "abrad export: note: " << transcoded
                  << " material or surface names were not UTF-8; read as Windows-1252 (Latin-1) "
                     "in "
                  << job.args.output << "\n";
}

void write_pov(const ExportJob& job) {
    const ToneMapped t = bake_of(job);
    const ViewArgs& view = job.args.view;
    const exporter::PovView v{.camera = camera_for(job.scene, view),
                              .width = view.width,
                              .height = view.height,
                              .exposure = t.tone.exposure,
                              .tone_mapped = job.args.pov_tone_map};
    exporter::write_pov(job.args.output, job.scene, t.bake.mesh, v);
    std::cout << "camera '" << v.camera.name << "'\n";
    report(job, t);
}

// The reference needs the scene only; the bake (when there is one) sets the exposure.
void write_pov_reference(const ExportJob& job) {
    const ViewArgs& view = job.args.view;
    double exposure = view.exposure.value_or(1.0);
    std::string from = "given";
    if (!view.exposure) {
        if (job.store.list_bakes().empty())
            bad_input(job.args.db + ": no bake to take the exposure from (give --exposure)");
        exposure =
            job.own_tone
                ? job.own_tone->exposure
                : exposure_for(load_bake_for(job.store, job.args.db, job.args.bake, "export"),
                               job.scene, view)
                      .exposure;
        from = "of the bake";
    }
    exporter::PovReferenceOptions o;
    o.view = {.camera = camera_for(job.scene, view),
              .width = view.width,
              .height = view.height,
              .exposure = exposure};
    o.light_samples = view.light_samples;
    o.bounces = view.reference_bounces;
    o.quality = view.quality == "low"    ? exporter::PovQuality::Low
                : view.quality == "high" ? exporter::PovQuality::High
                                         : exporter::PovQuality::Medium;
    exporter::write_pov_reference(job.args.output, job.scene, o);
    std::cout << "wrote " << job.args.output << " (pov-reference, camera '" << o.view.camera.name
              << "', "
              << (o.bounces ? std::to_string(o.bounces) + " POV-Ray radiosity bounces"
                            : std::string("direct light only"))
              << ", exposure " << exposure << " " << from << ")\n";
}

// One export format.
struct ExportFormat {
    std::string_view name;
    std::vector<std::string_view> extensions;  ///< lower case, with the dot
    bool by_extension;                         ///< an extension alone picks it
    std::vector<std::string_view> options;     ///< options only some formats use
    void (*write)(const ExportJob& job);
};

// The formats. An extension picks the first format listing it with by_extension set;
// --db, --output, --bake, --format and --exposure apply to every format.
const std::vector<ExportFormat>& export_formats() {
    static const std::vector<ExportFormat> kFormats = {
        {"ply",
         {".ply"},
         true,
         {"--ascii", "--up", "--positions", "--surface-ids", "--simplify", "--simplify-floor",
          "--simplify-refit", "--simplify-budget"},
         write_ply},
        {"obj",
         {".obj"},
         true,
         {"--up", "--simplify", "--simplify-floor", "--simplify-refit", "--simplify-budget"},
         write_obj},
        {"gltf",
         {".gltf", ".glb"},
         true,
         {"--simplify", "--simplify-floor", "--simplify-refit", "--simplify-budget"},
         write_gltf},
        {"pov",
         {".pov"},
         true,
         {"--camera", "--width", "--height", "--simplify", "--simplify-floor", "--simplify-refit",
          "--simplify-budget", "--pov-tone-map"},
         write_pov},
        {"pov-reference",
         {".pov"},
         false,
         {"--camera", "--width", "--height", "--light-samples", "--reference-bounces", "--quality"},
         write_pov_reference},
    };
    return kFormats;
}

const ExportFormat* find_format(std::string_view name) {
    for (const ExportFormat& f : export_formats())
        if (f.name == name) return &f;
    return nullptr;
}

bool lists(const std::vector<std::string_view>& list, std::string_view item) {
    return std::find(list.begin(), list.end(), item) != list.end();
}

std::string lower_extension(const std::string& path) {
    std::string ext = fs::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ext;
}

// The format the output's extension picks, or null.
const ExportFormat* format_of_extension(const std::string& ext) {
    for (const ExportFormat& f : export_formats())
        if (f.by_extension && lists(f.extensions, ext)) return &f;
    return nullptr;
}

// The format to write: --format (which must agree with a known extension), else the one the
// output's extension picks. Anything else is bad input.
const ExportFormat& choose_format(const ExportArgs& a) {
    const std::string ext = lower_extension(a.output);
    const ExportFormat* by_ext = format_of_extension(ext);
    if (a.format.empty()) {
        if (by_ext) return *by_ext;
        std::string known;
        for (const ExportFormat& f : export_formats())
            if (f.by_extension)
                for (std::string_view e : f.extensions)
                    known += (known.empty() ? "" : ", ") + std::string(e);
        bad_input(a.output + ": cannot tell the format from the extension '" + ext +
                  "' (known: " + known + "); give --format");
    }
    const ExportFormat* f = find_format(a.format);
    if (!f) bad_input("--format " + a.format + ": unknown format");
    if (by_ext && !lists(f->extensions, ext))
        bad_input("--format " + a.format + " contradicts the extension of " + a.output + " ('" +
                  ext + "' is " + std::string(by_ext->name) + ")");
    return *f;
}

// An option given but not used by the format is an error, never ignored.
void check_options_used(const CLI::App& app, const ExportFormat& format) {
    for (const ExportFormat& other : export_formats())
        for (std::string_view option : other.options) {
            if (lists(format.options, option) || app.count(std::string(option)) == 0) continue;
            std::string users;
            for (const ExportFormat& f : export_formats())
                if (lists(f.options, option))
                    users += (users.empty() ? "" : " and ") + std::string(f.name);
            bad_input(std::string(option) + " applies to --format " + users + " only; --format " +
                      std::string(format.name) + " does not use it");
        }
}

ExportArgs& state() {
    static ExportArgs s;
    return s;
}

}  // namespace

void export_bake(const ExportArgs& a) {
    const ExportFormat& format = choose_format(a);
    visdb::Store store = open_db(a.db);
    visdb::Scene scene = store.load_scene();
    // --scene-mix: the bake and the scene's lights dimmed by group (pov-reference lights the
    // dimmed scene)
    std::optional<visdb::Bake> mixed;
    std::optional<exporter::ToneMap> own_tone;
    if (!a.scene_mix.empty()) {
        mixed = load_bake_for(store, a.db, a.bake, "export");
        own_tone = exposure_for(*mixed, scene, a.view);
        mix_light_scene(a.scene_mix, scene, *mixed);
    }
    format.write({.args = a,
                  .format = format.name,
                  .store = store,
                  .scene = scene,
                  .mixed = mixed,
                  .own_tone = own_tone});
}

void add_export(CLI::App& app) {
    ExportArgs& s = state();
    std::vector<std::string> names;
    std::string help;
    for (const ExportFormat& f : export_formats()) {
        names.emplace_back(f.name);
        std::string exts;
        for (std::string_view e : f.extensions) exts += (exts.empty() ? "" : " ") + std::string(e);
        help += (help.empty() ? "" : ", ") + std::string(f.name) + " (" + exts +
                (f.by_extension ? "" : ", only when given") + ")";
    }
    app.add_option("--db", s.db, "Visual database")->required();
    app.add_option("--format", s.format,
                   "Format, else the output's extension picks it: " + help +
                       "; pov is the bake, unlit; pov-reference the model lit by POV-Ray")
        ->check(CLI::IsMember(names));
    app.add_option("--output", s.output, "Output path")->required();
    app.add_option("--bake", s.bake, "Bake name (default: the latest)");
    add_scene_mix_option(app, s.scene_mix);
    app.add_flag("--ascii", s.ascii, "PLY as ASCII instead of binary little endian");
    app.add_option("--up", s.up,
                   "The written file's up axis: y writes abrad's (x, y, z) as (x, z, -y) (default: "
                   "y for obj, OBJ's convention; z for ply; glTF is always Y up)")
        ->check(CLI::IsMember({"y", "z"}));
    app.add_option("--positions", s.positions,
                   "ply: vertex positions as double (absolute), or float relative to the "
                   "header's 'comment origin X Y Z' (for web loaders such as three.js)")
        ->capture_default_str()
        ->check(CLI::IsMember({"double", "float"}));
    app.add_option("--surface-ids", s.surface_ids,
                   "ply: each triangle's surface id as a face property (the contract), or as a "
                   "vertex property with faces holding vertex_indices only (for readers such as "
                   "meshio that cannot read a binary face element with more properties)")
        ->capture_default_str()
        ->check(CLI::IsMember({"face", "vertex"}));
    app.add_option("--simplify", s.simplify,
                   "Export a light mesh: the bake decimated while the irradiance at every "
                   "removed vertex changes by at most this fraction, in (0, 1] (1: no cap), "
                   "within the budget and refitted (as abrad simplify --error E --refit true "
                   "--budget 0.004, without storing it)");
    app.add_option("--simplify-floor", s.simplify_floor,
                   "With --simplify: as abrad simplify --floor (the bound's absolute floor, a "
                   "fraction of the brightest irradiance)")
        ->capture_default_str();
    app.add_option("--simplify-refit", s.simplify_refit,
                   "With --simplify: as abrad simplify --refit (least-squares values of the kept "
                   "vertices)")
        ->capture_default_str();
    app.add_option("--simplify-budget", s.simplify_budget,
                   "With --simplify: as abrad simplify --budget (area-weighted mean change "
                   "allowed, a fraction of the mean irradiance; 0: none)")
        ->capture_default_str();
    app.add_flag("--pov-tone-map", s.pov_tone_map,
                 "pov: vertex colours through the tone curve 1 - exp(-exposure B), for an 8-bit "
                 "PNG from POV-Ray (+FN) that looks like abrad render's, instead of linear "
                 "exposure x B for OpenEXR (+FE)");
    add_view_options(app, s.view);
    app.add_option("--light-samples", s.view.light_samples,
                   "pov-reference: point lights sampling the emitters (cos-weighted spotlights)")
        ->capture_default_str()
        ->check(CLI::Range(1, 1000000));
    app.add_option("--reference-bounces", s.view.reference_bounces,
                   "pov-reference: POV-Ray radiosity bounces (0 = off, direct light only)")
        ->capture_default_str()
        ->check(CLI::Range(0, 20));
    app.add_option("--quality", s.view.quality, "pov-reference: POV-Ray radiosity quality")
        ->capture_default_str()
        ->check(CLI::IsMember({"low", "medium", "high"}));
}

int run_export(const Invocation& call) {
    const ExportArgs& a = state();
    if (call.app.count("--simplify") > 0 && !a.simplify)  // CLI11 reads "" as no value
        bad_input("--simplify needs a bound in (0, 1]");
    check_options_used(call.app, choose_format(a));
    for (const char* option : {"--simplify-floor", "--simplify-refit", "--simplify-budget"})
        if (call.app.count(option) > 0 && !a.simplify)
            bad_input(std::string(option) + " applies to a light mesh only; give --simplify");
    if (a.simplify) check_simplify_options(simplify_options(a), kSimplifyNames);
    export_bake(a);
    return kExitOk;
}

}  // namespace abrad::tools::cli
