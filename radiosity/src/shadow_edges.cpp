// PLACEHOLDER: being written.
#include "abrad/radiosity/shadow_edges.h"
#include <stdexcept>
namespace abrad::radiosity {
ShadowStats& ShadowStats::operator+=(const ShadowStats& o) {
    edges_projected += o.edges_projected;
    shared_edges_skipped += o.shared_edges_skipped;
    segments_split += o.segments_split;
    segments += o.segments;
    return *this;
}
std::string to_string(LightModel m) {
    return m == LightModel::Centroid ? "centroid" : m == LightModel::Vertices ? "vertices" : "area";
}
std::optional<LightModel> parse_light_model(std::string_view t) {
    if (t == "centroid") return LightModel::Centroid;
    if (t == "vertices") return LightModel::Vertices;
    if (t == "area") return LightModel::Area;
    return std::nullopt;
}
std::vector<ShadowSegment> shadow_edges(const Patch&, LightModel, const Patch&, std::span<const Patch* const>,
                                        double, ShadowStats*) {
    throw std::logic_error("shadow_edges: not written yet");
}
}  // namespace abrad::radiosity
