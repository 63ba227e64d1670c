// POV-Ray 3.7 scenes: the bake as unlit Gouraud-shaded mesh2 objects (`pov`), and the same
// model lit by POV-Ray itself (`pov-reference`). Declarations in writers.h.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <string>

#include "abrad/export/render.h"
#include "abrad/export/writers.h"
#include "output.h"

namespace abrad::exporter {

namespace {

using detail::append_exact;
using detail::AtomicFile;

/// fade_distance of the reference's point lights, metres (attenuation 2 F²/d² within (F/d)²).
constexpr double kFadeDistance = 1e-4;
/// How far in front of its emitter a point light sits, metres (clear of a coplanar ceiling).
constexpr double kLightOffset = 1e-3;

void append_vector(std::string& out, const glm::dvec3& v) {
    out += '<';
    append_exact(out, v.x);
    out += ',';
    append_exact(out, v.y);
    out += ',';
    append_exact(out, v.z);
    out += '>';
}

void append_vector_f(std::string& out, const glm::dvec3& v) {
    out += '<';
    append_exact(out, static_cast<float>(v.x));
    out += ',';
    append_exact(out, static_cast<float>(v.y));
    out += ',';
    append_exact(out, static_cast<float>(v.z));
    out += '>';
}

/// A comment-safe name: no newlines.
std::string comment_name(std::string_view name) {
    std::string s(name);
    for (char& c : s)
        if (c == '\n' || c == '\r') c = ' ';
    return s;
}

/// The preamble both exports share: version, exposure, global settings head, camera.
std::string preamble(const std::filesystem::path& path, const PovView& view,
                     std::string_view what) {
    const CameraFrame f = camera_frame(view.camera, view.width, view.height);
    std::string out;
    out += "// abrad: ";
    out += what;
    if (view.tone_mapped) {
        out += "\n// Render (8-bit sRGB PNG, colours = 1 - exp(-exposure x radiosity), exposure ";
        append_exact(out, view.exposure);
        out += "):\n//   povray +I";
    } else {
        out += "\n// Render (linear OpenEXR, values = Abrad_Exposure x radiosity):\n//   povray +I";
    }
    out += path.filename().string();
    out += " +O" + path.stem().string() + (view.tone_mapped ? ".png +FN" : ".exr +FE") + " +W" +
           std::to_string(view.width) + " +H" + std::to_string(view.height) + " -A -D\n";
    out += "// Frame: abrad's, Z up, metres; camera '" + comment_name(view.camera.name) + "'.\n";
    out += "#version 3.7;\n";
    if (!view.tone_mapped) {
        out += "#ifndef (Abrad_Exposure)\n  #declare Abrad_Exposure = ";
        append_exact(out, view.exposure);
        out += ";\n#end\n";
    }
    out += "background { rgb 0 }\ncamera {\n  perspective\n  location ";
    append_vector(out, f.eye);
    out += "\n  direction ";
    append_vector(out, f.forward);
    out += "\n  right ";
    append_vector(out, f.right * f.right_extent);
    out += "\n  up ";
    append_vector(out, f.up * f.up_extent);
    out += "\n}\n";
    return out;
}

}  // namespace

void write_pov(const std::filesystem::path& path, const visdb::Scene& scene,
               const visdb::BakeMesh& mesh, const PovView& view) {
    detail::validate_bake_mesh(path, mesh);
    std::string out;
    try {
        out = preamble(path, view,
                       view.tone_mapped
                           ? "baked radiosity tone-mapped per vertex, shown unlit, "
                             "Gouraud-interpolated (abrad export --format pov --pov-tone-map)"
                           : "baked radiosity shown unlit, Gouraud-interpolated (abrad export "
                             "--format pov)");
    } catch (const std::invalid_argument& e) {
        detail::fail(path, e.what());
    }
    out += "global_settings { assumed_gamma 1.0 ambient_light 0 max_trace_level 1 }\n";
    out += view.tone_mapped
               ? "#declare Abrad_Finish = finish { ambient 0 diffuse 0 emission 1 }\n"
               : "#declare Abrad_Finish = finish { ambient 0 diffuse 0 emission Abrad_Exposure }\n";
    // A bake shades the front of each face only: backs are black, as in abrad render
    out +=
        "#declare Abrad_Back = texture { pigment { rgb 0 } finish { ambient 0 diffuse 0 emission 0 "
        "} }\n";
    // Vertices relative to the local origin (visdb::local_origin) and a translate: POV-Ray's
    // single-precision mesh vertices keep millimetres at survey coordinates
    const glm::dvec3 origin = visdb::local_origin(mesh.positions);

    // Group the triangles by surface: one mesh2 per surface
    std::vector<std::uint32_t> order(mesh.triangles.size());
    for (std::uint32_t t = 0; t < order.size(); ++t) order[t] = t;
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        return mesh.triangle_surface[a] < mesh.triangle_surface[b];
    });

    AtomicFile file(path);
    std::vector<std::int64_t> local(mesh.positions.size(), -1);
    std::vector<std::uint32_t> used;
    for (std::size_t begin = 0; begin < order.size();) {
        const std::uint32_t surface = mesh.triangle_surface[order[begin]];
        std::size_t end = begin;
        while (end < order.size() && mesh.triangle_surface[order[end]] == surface) ++end;
        // Renumber this surface's vertices
        used.clear();
        for (std::size_t k = begin; k < end; ++k)
            for (int c = 0; c < 3; ++c) {
                const std::uint32_t v = mesh.triangles[order[k]][c];
                if (local[v] < 0) {
                    local[v] = static_cast<std::int64_t>(used.size());
                    used.push_back(v);
                }
            }
        out += "// surface " + std::to_string(surface);
        if (surface < scene.surfaces.size())
            out += " '" + comment_name(scene.surfaces[surface].name) + "'";
        out += "\nmesh2 {\n  vertex_vectors { " + std::to_string(used.size());
        for (const std::uint32_t v : used) {
            out += ",\n    ";
            append_vector_f(out, mesh.positions[v] - origin);
        }
        out += " }\n  texture_list { " + std::to_string(used.size());
        for (const std::uint32_t v : used) {
            const glm::vec3& b = mesh.radiosity[v];
            out += ",\n    texture{pigment{rgb<";
            for (int c = 0; c < 3; ++c) {
                if (c) out += ',';
                const float value = std::isfinite(b[c]) && b[c] > 0.0f ? b[c] : 0.0f;
                if (view.tone_mapped)
                    append_exact(out, static_cast<float>(
                                          tone_value(value, ToneMap{.exposure = view.exposure})));
                else
                    append_exact(out, value);
            }
            out += ">}finish{Abrad_Finish}}";
            file.write_if_full(out);
        }
        out += " }\n  face_indices { " + std::to_string(end - begin);
        for (std::size_t k = begin; k < end; ++k) {
            const auto& t = mesh.triangles[order[k]];
            // POV-Ray's front is the left-handed one: write b and c swapped so the bake's front
            // gets the texture_list and its back the black interior_texture
            const std::string a = std::to_string(local[t.x]), b = std::to_string(local[t.z]),
                              c = std::to_string(local[t.y]);
            for (const char* piece : {",\n    <", a.c_str(), ",", b.c_str(), ",", c.c_str(), ">,",
                                      a.c_str(), ",", b.c_str(), ",", c.c_str()})
                out += piece;
            file.write_if_full(out);
        }
        out += " }\n  texture { Abrad_Back }\n  interior_texture { Abrad_Back }\n  translate ";
        append_vector(out, origin);
        out += "\n}\n";
        for (const std::uint32_t v : used) local[v] = -1;
        file.write_if_full(out);
        begin = end;
    }
    file.write(out);
    file.commit();
}

void write_pov_reference(const std::filesystem::path& path, const visdb::Scene& scene,
                         const PovReferenceOptions& options) {
    if (options.light_samples < 1) detail::fail(path, "light_samples must be at least 1");
    if (options.bounces < 0 || options.bounces > 20)
        detail::fail(path, "bounces must be in [0, 20]");
    std::string out;
    try {
        out = preamble(
            path, options.view,
            "the model lit by POV-Ray (abrad export --format pov-reference): point lights "
            "sampling Lambertian emitters" +
                std::string(options.bounces > 0 ? ", POV-Ray radiosity" : ", direct light only"));
    } catch (const std::invalid_argument& e) {
        detail::fail(path, e.what());
    }

    // Radiosity settings by quality
    out += "global_settings {\n  assumed_gamma 1.0\n  ambient_light 0\n  max_trace_level 8\n";
    if (options.bounces > 0) {
        struct Q {
            int count;
            const char* error_bound;
            const char* pretrace_end;
        };
        const Q q = options.quality == PovQuality::Low      ? Q{60, "1.5", "0.04"}
                    : options.quality == PovQuality::Medium ? Q{200, "0.6", "0.01"}
                                                            : Q{800, "0.25", "0.005"};
        out += "  radiosity {\n    count " + std::to_string(q.count) + "\n    error_bound " +
               q.error_bound + "\n    recursion_limit " + std::to_string(options.bounces) +
               "\n    pretrace_start 0.08\n    pretrace_end " + q.pretrace_end +
               "\n    nearest_count 10\n    low_error_factor 0.5\n    gray_threshold 0\n"
               "    minimum_reuse 0.01\n    brightness 1\n    adc_bailout 0.005\n  }\n";
    }
    out += "}\n";

    out +=
        "#declare Abrad_Back = texture { pigment { rgb 0 } finish { ambient 0 diffuse 0 emission 0 "
        "} }\n";
    // One texture per material
    for (std::size_t m = 0; m < scene.materials.size(); ++m) {
        const visdb::Material& mat = scene.materials[m];
        out += "// material '" + comment_name(mat.name) + "'\n#declare Abrad_M" +
               std::to_string(m) + " = texture { pigment { rgbt <";
        if (mat.is_emitter()) {
            // Emitters show their exitance; their light comes from the point lights below
            for (int c = 0; c < 3; ++c) {
                append_exact(out, std::max(mat.emittance[c], 0.0));
                out += ',';
            }
            out += "0> } finish { ambient 0 diffuse 0 emission Abrad_Exposure } }\n";
        } else {
            for (int c = 0; c < 3; ++c) {
                append_exact(out, std::clamp(mat.reflectance[c], 0.0, 1.0));
                out += ',';
            }
            append_exact(out, std::clamp(1.0 - mat.opacity, 0.0, 1.0));
            out += "> } finish { ambient 0 emission 0 diffuse 1 } }\n";
        }
    }

    std::vector<glm::dvec3> all;
    for (const auto& s : scene.surfaces)
        all.insert(all.end(), s.mesh.positions.begin(), s.mesh.positions.end());
    const glm::dvec3 origin = visdb::local_origin(all);

    AtomicFile file(path);
    double emitting_area = 0.0;
    for (std::size_t si = 0; si < scene.surfaces.size(); ++si) {
        const visdb::Surface& s = scene.surfaces[si];
        if (s.material >= scene.materials.size())
            detail::fail(path, "surface " + std::to_string(si) + " has material " +
                                   std::to_string(s.material) + " out of range (" +
                                   std::to_string(scene.materials.size()) + " materials)");
        if (s.mesh.triangles.empty()) continue;
        const bool emitter = scene.materials[s.material].is_emitter();
        out += "// surface " + std::to_string(si) + " '" + comment_name(s.name) +
               "'\nmesh2 {\n  vertex_vectors { " + std::to_string(s.mesh.positions.size());
        for (const auto& p : s.mesh.positions) {
            out += ",\n    ";
            append_vector_f(out, p - origin);
        }
        out += " }\n  face_indices { " + std::to_string(s.mesh.triangles.size());
        for (const auto& t : s.mesh.triangles) {
            if (t.x >= s.mesh.positions.size() || t.y >= s.mesh.positions.size() ||
                t.z >= s.mesh.positions.size())
                detail::fail(path,
                             "surface " + std::to_string(si) + ": triangle index out of range");
            // Reversed: POV-Ray's front is left-handed (only the emitters' interior_texture
            // cares; diffuse shading is two-sided)
            out += ",\n    <" + std::to_string(t.x) + "," + std::to_string(t.z) + "," +
                   std::to_string(t.y) + ">";
            if (emitter) {
                emitting_area += visdb::triangle_area(s.mesh.positions[t.x], s.mesh.positions[t.y],
                                                      s.mesh.positions[t.z]);
            }
        }
        out += " }\n  texture { Abrad_M" + std::to_string(s.material) + " }\n";
        // Emitters emit from their front only: their backs are black, as in the bake
        if (emitter) out += "  interior_texture { Abrad_Back }\n";
        out += "  translate ";
        append_vector(out, origin);
        out += emitter ? "\n  no_shadow\n  no_radiosity\n}\n" : "\n}\n";
        file.write_if_full(out);
    }

    // Point lights sampling every emitter triangle (Lambertian: spotlight with tightness 1)
    std::size_t lights = 0;
    for (const auto& s : scene.surfaces) {
        const visdb::Material& mat = scene.materials[s.material];
        if (!mat.is_emitter()) continue;
        for (const auto& t : s.mesh.triangles) {
            const glm::dvec3 &a = s.mesh.positions[t.x], &b = s.mesh.positions[t.y],
                             &c = s.mesh.positions[t.z];
            const glm::dvec3 cr = glm::cross(b - a, c - a);
            const double area = 0.5 * glm::length(cr);
            if (!(area > 0.0)) continue;
            const glm::dvec3 n = cr / (2.0 * area);
            const int k = std::max(
                1, static_cast<int>(std::lround(std::sqrt(
                       static_cast<double>(options.light_samples) * area / emitting_area))));
            const double da = area / (static_cast<double>(k) * static_cast<double>(k));
            // Colour E dA / (2 π F²): with fade 2F²/d² and cos θ at both ends this is dE = E dA cos
            // cos / (π d²)
            const glm::dvec3 colour =
                mat.emittance * da / (2.0 * std::numbers::pi * kFadeDistance * kFadeDistance);
            const glm::dvec3 u = (b - a) / static_cast<double>(k),
                             v = (c - a) / static_cast<double>(k);
            // The k² sub-triangles: k(k+1)/2 pointing like the triangle, k(k-1)/2 inverted
            auto emit = [&](const glm::dvec3& centroid) {
                const glm::dvec3 p = centroid + kLightOffset * n;
                out += "light_source { ";
                append_vector(out, p);
                out += ", rgb Abrad_Exposure*";
                append_vector(out, glm::max(colour, glm::dvec3(0.0)));
                out += " spotlight point_at ";
                append_vector(out, p + n);
                out += " radius 89.99 falloff 90 tightness 1 fade_distance ";
                append_exact(out, kFadeDistance);
                out += " fade_power 2 }\n";
                ++lights;
                file.write_if_full(out);
            };
            for (int i = 0; i < k; ++i)
                for (int j = 0; i + j < k; ++j) {
                    const glm::dvec3 p0 =
                        a + static_cast<double>(i) * u + static_cast<double>(j) * v;
                    emit(p0 + (u + v) / 3.0);
                    if (i + j + 1 < k) emit(p0 + 2.0 * (u + v) / 3.0);
                }
        }
    }
    out += "// " + std::to_string(lights) + " point lights\n";
    file.write(out);
    file.commit();
}

}  // namespace abrad::exporter
