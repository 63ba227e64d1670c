#pragma once
// A luminaire's luminous intensity distribution (its photometric web) and its luminous
// opening, as read from an IES LM-63 or EULUMDAT file: plain model types the bake samples and
// the store keeps. Header only, like the rest of the model.
//
// The luminaire's photometric frame: +x along the luminaire's length (the C = 0 plane), +y
// across it (C = 90), +z up; a downlight sends its light toward -z (nadir, γ = 0).
//   Type C (polar axis z): d = (sin γ cos C, sin γ sin C, -cos γ); C counter-clockwise seen
//     from above, γ from nadir (0) to zenith (180).
//   Type B (polar axis y): d = (cos V sin H, sin V, -cos V cos H); H about the y axis from
//     nadir toward +x, V the elevation toward +y (floodlights: H = V = 0 is the aim).
//   Type A (polar axis x): Type B turned 90° about z: d = (-sin V, cos V sin H, -cos V cos H).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <glm/vec3.hpp>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

namespace abrad::visdb {

/// The goniometer's coordinate system (the LM-63 code: C = 1, B = 2, A = 3).
enum class PhotometricType { C = 1, B = 2, A = 3 };

/// "C", "B" or "A".
inline const char* to_string(PhotometricType type) {
    switch (type) {
        case PhotometricType::B:
            return "B";
        case PhotometricType::A:
            return "A";
        case PhotometricType::C:
            break;
    }
    return "C";
}

/// A web of luminous intensities, candela, on a grid of angles in degrees, interpolated
/// bilinearly in the two angles and zero outside the grid. Symmetries are already unfolded:
///  - type C: `horizontal` is either {0} (rotationally symmetric) or runs from 0 to 360
///    inclusive (periodic: the 360 column repeats the 0 column); `vertical` (γ) lies in
///    [0, 180] (a web of 0..90 is dark above the horizon);
///  - types A and B: `horizontal` lies in [-180, 180], `vertical` in [-90, 90].
/// Both angle lists are strictly increasing; `vertical` has at least two angles, `horizontal`
/// at least two unless it is the type C {0}.
struct PhotometricWeb {
    PhotometricType type = PhotometricType::C;
    std::vector<double> horizontal;  ///< degrees: C, or H (types A, B)
    std::vector<double> vertical;    ///< degrees: γ, or V (types A, B)
    std::vector<double> candela;     ///< candela[h * vertical.size() + v] >= 0

    /// True when the type C web does not depend on C.
    bool rotationally_symmetric() const { return horizontal.size() == 1; }

    /// Intensity (cd) at the web's own angles (degrees): bilinear between the four nearest
    /// samples; 0 outside the grid. Type C angles are taken modulo 360 for C.
    double intensity(double h_deg, double v_deg) const {
        if (type == PhotometricType::C) {
            h_deg = std::fmod(h_deg, 360.0);
            if (h_deg < 0.0) h_deg += 360.0;
        }
        double tv = 0.0;
        std::size_t iv = 0;
        if (!bracket(vertical, v_deg, iv, tv)) return 0.0;
        if (horizontal.size() == 1) return lerp(at(0, iv), at(0, iv + 1), tv);
        double th = 0.0;
        std::size_t ih = 0;
        if (!bracket(horizontal, h_deg, ih, th)) return 0.0;
        const double low = lerp(at(ih, iv), at(ih, iv + 1), tv);
        const double high = lerp(at(ih + 1, iv), at(ih + 1, iv + 1), tv);
        return lerp(low, high, th);
    }

    /// Intensity (cd) toward the unit direction `d` of the photometric frame (see above).
    double intensity(const glm::dvec3& d) const {
        const auto [h, v] = angles(d);
        return intensity(h, v);
    }

    /// The web's (horizontal, vertical) angles in degrees of the unit direction `d`.
    std::pair<double, double> angles(const glm::dvec3& d) const {
        constexpr double kDeg = 180.0 / std::numbers::pi;
        const auto clamp1 = [](double x) { return std::clamp(x, -1.0, 1.0); };
        switch (type) {
            case PhotometricType::B:
                return {std::atan2(d.x, -d.z) * kDeg, std::asin(clamp1(d.y)) * kDeg};
            case PhotometricType::A:
                return {std::atan2(d.y, -d.z) * kDeg, std::asin(clamp1(-d.x)) * kDeg};
            case PhotometricType::C:
                break;
        }
        const double c = d.x == 0.0 && d.y == 0.0 ? 0.0 : std::atan2(d.y, d.x) * kDeg;
        return {c < 0.0 ? c + 360.0 : c, std::acos(clamp1(-d.z)) * kDeg};
    }

    /// The unit direction of the photometric frame at the web's angles (degrees).
    glm::dvec3 direction(double h_deg, double v_deg) const {
        constexpr double kRad = std::numbers::pi / 180.0;
        const double h = h_deg * kRad;
        const double v = v_deg * kRad;
        switch (type) {
            case PhotometricType::B:
                return {std::cos(v) * std::sin(h), std::sin(v), -std::cos(v) * std::cos(h)};
            case PhotometricType::A:
                return {-std::sin(v), std::cos(v) * std::sin(h), -std::cos(v) * std::cos(h)};
            case PhotometricType::C:
                break;
        }
        return {std::sin(v) * std::cos(h), std::sin(v) * std::sin(h), -std::cos(v)};
    }

    /// Total luminous flux (lm): the exact integral over the sphere of the interpolated web
    /// (bilinear in the angles, as `intensity` gives it), Φ = ∫ I dω with dω = sin γ dγ dC
    /// (type C) or cos V dV dH (types A, B).
    double flux() const {
        constexpr double kRad = std::numbers::pi / 180.0;
        const bool type_c = type == PhotometricType::C;
        // Weights of the two ends of a vertical interval [a, b] (radians) against the solid
        // angle's factor: ∫ w(v) f(v) dv for the linear hat functions w, f = sin (type C
        // γ) or cos (V). With F' = f and G' = F (F = -cos, G = -sin for sin; F = sin,
        // G = -cos for cos): ∫_a^b (b - v) f dv = [(b - v) F + G]_a^b, and so on.
        const auto F = [&](double v) { return type_c ? -std::cos(v) : std::sin(v); };
        const auto G = [&](double v) { return type_c ? -std::sin(v) : -std::cos(v); };
        const std::size_t nv = vertical.size();
        std::vector<double> column_weight(nv, 0.0);  // ∫ of each vertical hat function
        for (std::size_t i = 0; i + 1 < nv; ++i) {
            const double a = vertical[i] * kRad;
            const double b = vertical[i + 1] * kRad;
            const double len = b - a;
            // ∫_a^b (b - v)/len f dv and ∫_a^b (v - a)/len f dv
            const double lower = (G(b) - ((b - a) * F(a) + G(a))) / len;
            const double upper = ((b - a) * F(b) - G(b) + G(a)) / len;
            column_weight[i] += lower;
            column_weight[i + 1] += upper;
        }
        const auto column = [&](std::size_t h) {
            double s = 0.0;
            for (std::size_t v = 0; v < nv; ++v) s += column_weight[v] * at(h, v);
            return s;
        };
        if (horizontal.size() == 1) return 2.0 * std::numbers::pi * column(0);
        double total = 0.0;
        for (std::size_t h = 0; h + 1 < horizontal.size(); ++h) {
            total += 0.5 * (horizontal[h + 1] - horizontal[h]) * kRad * (column(h) + column(h + 1));
        }
        return total;
    }

    /// The largest intensity of the web, cd.
    double max_candela() const {
        return candela.empty() ? 0.0 : *std::max_element(candela.begin(), candela.end());
    }

    /// "type C, 2 x 19 angles (C 0..360, γ 0..90), 1000 cd max, 3141.6 lm".
    std::string to_string() const;

  private:
    double at(std::size_t h, std::size_t v) const { return candela[h * vertical.size() + v]; }
    static double lerp(double a, double b, double t) { return a + (b - a) * t; }
    /// Finds i with angles[i] <= x <= angles[i + 1] and the fraction t; false outside.
    static bool bracket(const std::vector<double>& angles, double x, std::size_t& i, double& t) {
        if (!(x >= angles.front() && x <= angles.back()) || angles.size() < 2) return false;
        const auto it = std::upper_bound(angles.begin(), angles.end(), x);
        i = it == angles.end() ? angles.size() - 2
                               : static_cast<std::size_t>(it - angles.begin()) - 1;
        t = (x - angles[i]) / (angles[i + 1] - angles[i]);
        return true;
    }
};

inline std::string PhotometricWeb::to_string() const {
    const auto num = [](double v) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%g", v);
        return std::string(buf);
    };
    const char* h = type == PhotometricType::C ? "C" : "H";
    const char* v = type == PhotometricType::C ? "gamma" : "V";
    std::string s = "type " + std::string(visdb::to_string(type)) + ", " +
                    std::to_string(horizontal.size()) + " x " + std::to_string(vertical.size()) +
                    " angles (";
    s += std::string(h) + " " + (horizontal.empty() ? "-" : num(horizontal.front())) + ".." +
         (horizontal.empty() ? "-" : num(horizontal.back())) + ", " + v + " " +
         (vertical.empty() ? "-" : num(vertical.front())) + ".." +
         (vertical.empty() ? "-" : num(vertical.back())) + "), ";
    s += num(max_candela()) + " cd max, " + num(flux()) + " lm";
    return s;
}

/// The luminous opening of a luminaire (LM-63-2002's shapes; EULUMDAT gives rectangles and
/// discs), metres, in the photometric frame: `length` along x, `width` along y, `height` along
/// z, centred on the photometric centre.
struct LuminousOpening {
    enum class Shape {
        Point,                ///< 0 0 0
        Rectangle,            ///< horizontal, width x length
        Box,                  ///< rectangle with luminous sides of `height`
        Disc,                 ///< horizontal circle or ellipse, diameters width x length
        VerticalCylinder,     ///< (elliptic) cylinder of `height` standing on the disc
        Sphere,               ///< ellipsoid of diameters width, length, height
        CylinderAlongX,       ///< horizontal cylinder along the length, diameters width, height
        CylinderAlongY,       ///< horizontal cylinder across, diameters length, height
        VerticalDiscFacingX,  ///< vertical circle or ellipse facing ±x: width x height
        VerticalDiscFacingY,  ///< vertical circle or ellipse facing ±y: length x height
    };
    Shape shape = Shape::Point;
    double width = 0.0;   ///< metres, along y
    double length = 0.0;  ///< metres, along x
    double height = 0.0;  ///< metres, along z

    /// The largest extent, metres (0 for a point): what the five-times rule compares with.
    double size() const { return std::max({width, length, height}); }
};

/// "point", "rectangle", ...
inline const char* to_string(LuminousOpening::Shape shape) {
    using S = LuminousOpening::Shape;
    switch (shape) {
        case S::Point:
            return "point";
        case S::Rectangle:
            return "rectangle";
        case S::Box:
            return "box";
        case S::Disc:
            return "disc";
        case S::VerticalCylinder:
            return "vertical cylinder";
        case S::Sphere:
            return "sphere";
        case S::CylinderAlongX:
            return "horizontal cylinder along x";
        case S::CylinderAlongY:
            return "horizontal cylinder along y";
        case S::VerticalDiscFacingX:
            return "vertical disc facing x";
        case S::VerticalDiscFacingY:
            return "vertical disc facing y";
    }
    return "point";
}

}  // namespace abrad::visdb
