#pragma once
// Light scenes without re-baking: light is linear in the sources, so a bake that stored its
// shades per light group (Bake::light_groups) gives any mix of the groups with dimming
// factors, as DIALux's light scenes do (docs/design.md, "Light scenes").

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "abrad/visdb/model.h"

namespace abrad::visdb {

/// The light group of a luminaire: its `group`, else its photometric file's stem.
inline std::string light_group(const Luminaire& l) {
    if (!l.group.empty()) return l.group;
    const std::size_t slash = l.file.find_last_of("/\\");
    std::string stem = slash == std::string::npos ? l.file : l.file.substr(slash + 1);
    const std::size_t dot = stem.rfind('.');
    if (dot != std::string::npos && dot > 0) stem.resize(dot);
    return stem;
}

/// The light group of an emitting material: its `group`, else kEmitterGroup.
inline std::string light_group(const Material& m) {
    return m.group.empty() ? std::string(kEmitterGroup) : m.group;
}

/// True iff some light of `scene` (an emitting material or a luminaire) names its group: only
/// then does a bake store its shades per group.
inline bool names_light_groups(const Scene& scene) {
    for (const Material& m : scene.materials)
        if (m.is_emitter() && !m.group.empty()) return true;
    for (const Luminaire& l : scene.luminaires)
        if (!l.group.empty()) return true;
    return false;
}

/// The light groups of `scene`'s lights in first-seen order (emitting materials, then
/// luminaires).
inline std::vector<std::string> light_groups(const Scene& scene) {
    std::vector<std::string> names;
    const auto add = [&](const std::string& g) {
        for (const std::string& n : names)
            if (n == g) return;
        names.push_back(g);
    };
    for (const Material& m : scene.materials)
        if (m.is_emitter()) add(light_group(m));
    for (const Luminaire& l : scene.luminaires) add(light_group(l));
    return names;
}

/// A light scene: dimming factors per group; a group not named keeps factor 1.
struct SceneMix {
    std::vector<std::pair<std::string, double>> factors;

    /// The factor of group `name` (1 when not named).
    double factor(const std::string& name) const {
        for (const auto& [n, f] : factors)
            if (n == name) return f;
        return 1.0;
    }
    /// True iff every named factor is exactly 1 (the bake's own mix).
    bool is_identity() const {
        for (const auto& nf : factors)
            if (nf.second != 1.0) return false;
        return true;
    }
    std::string to_string() const {
        std::string s;
        for (const auto& [n, f] : factors) {
            if (!s.empty()) s += ",";
            s += n + "=" + std::to_string(f);
        }
        return s;
    }
};

/// Parses "office=1,corridor=0.3": comma-separated NAME=FACTOR, each factor a finite number
/// >= 0, each name once and not empty (blanks around names and factors are ignored). Throws
/// std::invalid_argument naming the item.
inline SceneMix parse_scene_mix(std::string_view text) {
    const auto trim = [](std::string_view s) {
        while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
        while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
        return s;
    };
    SceneMix mix;
    std::size_t start = 0;
    while (start <= text.size()) {
        const std::size_t comma = std::min(text.find(',', start), text.size());
        const std::string_view item = trim(text.substr(start, comma - start));
        const std::size_t eq = item.find('=');
        const std::string quoted = "'" + std::string(item) + "'";
        if (eq == std::string_view::npos)
            throw std::invalid_argument("item " + quoted + " is not NAME=FACTOR");
        const std::string name(trim(item.substr(0, eq)));
        const std::string value(trim(item.substr(eq + 1)));
        if (name.empty()) throw std::invalid_argument("item " + quoted + " has no group name");
        double f = NAN;
        std::size_t used = 0;
        try {
            f = std::stod(value, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used == 0 || used != value.size() || !std::isfinite(f) || f < 0.0)
            throw std::invalid_argument("item " + quoted +
                                        ": the factor must be a finite number >= 0");
        for (const auto& other : mix.factors)
            if (other.first == name)
                throw std::invalid_argument("group '" + name + "' is given twice");
        mix.factors.emplace_back(name, f);
        start = comma + 1;
    }
    return mix;
}

/// Applies `mix` to a bake and the scene it was baked from: every vertex's irradiance and
/// radiosity become Σ factor(g) · the group's shades (in double, rounded once to float), and
/// the scene's lights are dimmed alike (emitting materials' emittance, luminaires'
/// flux_scale), so that what is computed afresh from the scene (exact direct light at probes
/// and grid points) agrees. The identity mix leaves both untouched, bit for bit. Throws
/// std::invalid_argument when the mix names a group the bake does not have, or the bake has
/// no groups and the mix is not the identity.
inline void apply_scene_mix(const SceneMix& mix, Scene& scene, Bake& bake) {
    std::string known;
    for (const LightGroupShades& g : bake.light_groups)
        known += (known.empty() ? "'" : ", '") + g.name + "'";
    for (const auto& [name, f] : mix.factors) {
        bool found = false;
        for (const LightGroupShades& g : bake.light_groups) found = found || g.name == name;
        if (!found)
            throw std::invalid_argument(
                "bake '" + bake.name + "' has no light group '" + name + "'" +
                (known.empty() ? " (it stored no light groups: its scene named none, or its "
                                 "lights were of one group)"
                               : " (its groups: " + known + ")"));
    }
    if (mix.is_identity()) return;
    const std::size_t n = bake.mesh.positions.size();
    std::vector<glm::dvec3> h(n, glm::dvec3(0.0)), b(n, glm::dvec3(0.0));
    for (const LightGroupShades& g : bake.light_groups) {
        const double f = mix.factor(g.name);
        if (f == 0.0) continue;
        for (std::size_t v = 0; v < n; ++v) {
            h[v] += f * glm::dvec3(g.irradiance[v]);
            b[v] += f * glm::dvec3(g.radiosity[v]);
        }
    }
    for (std::size_t v = 0; v < n; ++v) {
        bake.mesh.irradiance[v] = glm::vec3(h[v]);
        bake.mesh.radiosity[v] = glm::vec3(b[v]);
    }
    for (Material& m : scene.materials)
        if (m.is_emitter()) m.emittance *= mix.factor(light_group(m));
    for (Luminaire& l : scene.luminaires) l.flux_scale *= mix.factor(light_group(l));
}

}  // namespace abrad::visdb
