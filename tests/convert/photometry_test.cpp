// Tests of the IES LM-63 and EULUMDAT readers: every variant the formats allow parses and
// unfolds to the web written, integrated fluxes against closed forms (a uniform sphere 4πI, a
// cosine lower hemisphere πI0), and every malformed file is refused at its line with its field.

#include "abrad/convert/photometry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <glm/geometric.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "temp_dir.h"

namespace abrad::convert {
namespace {

using visdb::LuminousOpening;
using visdb::PhotometricType;
using visdb::PhotometricWeb;

constexpr double kPi = std::numbers::pi;
constexpr double kRad = kPi / 180.0;

std::string g17(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

/// Angles from `first` to `last` in steps of `step`.
std::vector<double> range(double first, double last, double step) {
    std::vector<double> a;
    const int n = static_cast<int>(std::lround((last - first) / step));
    for (int i = 0; i <= n; ++i) a.push_back(first + step * i);
    return a;
}

using Candela = std::function<double(double h, double v)>;

/// An IES file, laid out one group a line: the luminaire line, the ballast line, the vertical
/// angles, the horizontal angles, then one line of candela per horizontal angle.
struct Ies {
    std::string version = "IESNA:LM-63-2002";  ///< empty: a 1986 file without one
    std::string tilt = "TILT=NONE";
    std::string tilt_data;  ///< the lines after TILT=INCLUDE
    std::string lamps = "1";
    double lumens = 1000.0;
    double multiplier = 1.0;
    int type = 1;
    int units = 2;
    double width = 0.0, length = 0.0, height = 0.0;
    double ballast = 1.0, third = 1.0, watts = 20.0;
    std::vector<double> vertical = range(0.0, 90.0, 10.0);
    std::vector<double> horizontal = {0.0};
    Candela cd = [](double, double) { return 100.0; };

    std::string text() const {
        std::string s;
        if (!version.empty()) s += version + "\n";
        s += "[TEST] abrad photometry_test\n[MANUFAC] Abrad Lighting\n[LUMINAIRE] Test web\n";
        s += tilt + "\n" + tilt_data;
        s += lamps + " " + g17(lumens) + " " + g17(multiplier) + " " +
             std::to_string(vertical.size()) + " " + std::to_string(horizontal.size()) + " " +
             std::to_string(type) + " " + std::to_string(units) + " " + g17(width) + " " +
             g17(length) + " " + g17(height) + "\n";
        s += g17(ballast) + " " + g17(third) + " " + g17(watts) + "\n";
        for (const double v : vertical) s += g17(v) + " ";
        s += "\n";
        for (const double h : horizontal) s += g17(h) + " ";
        s += "\n";
        for (const double h : horizontal) {
            for (const double v : vertical) s += g17(cd(h, v)) + " ";
            s += "\n";
        }
        return s;
    }
    PhotometricFile read() const { return read_ies(text(), "test.ies"); }
};

/// An EULUMDAT file with Mc planes every 360/Mc degrees and the planes its Isym needs.
struct Ldt {
    int isym = 0;
    int mc = 24;
    std::vector<double> gammas = range(0.0, 180.0, 5.0);
    double lamp_flux = 2000.0;
    double lorl = 80.0;
    double conversion = 1.0;
    double area_length = 600.0, area_width = 300.0, area_height = 0.0;
    Candela cdklm = [](double, double) { return 100.0; };

    std::vector<double> c_angles() const { return range(0.0, 360.0 - 360.0 / mc, 360.0 / mc); }

    std::string text() const {
        const std::vector<double> c = c_angles();
        std::string s = "Abrad Lighting\n1\n" + std::to_string(isym) + "\n" + std::to_string(mc) +
                        "\n" + g17(360.0 / mc) + "\n" + std::to_string(gammas.size()) + "\n" +
                        "0\nreport 1\nTest web\nT-1\ntest.ldt\n2026-11-30\n";
        s += "1200\n400\n80\n" + g17(area_length) + "\n" + g17(area_width) + "\n";
        for (int i = 0; i < 4; ++i) s += g17(area_height) + "\n";
        s += "100\n" + g17(lorl) + "\n" + g17(conversion) + "\n0\n1\n";
        s += "2\nT5 28W\n" + g17(lamp_flux) + "\n3000K\n80\n62\n";
        for (int k = 0; k < 10; ++k) s += "0.5\n";
        for (const double a : c) s += g17(a) + "\n";
        for (const double g : gammas) s += g17(g) + "\n";
        std::size_t first = 0;
        std::size_t count = c.size();
        if (isym == 1) count = 1;
        if (isym == 2) count = c.size() / 2 + 1;
        if (isym == 3) first = c.size() / 4, count = c.size() / 2 + 1;
        if (isym == 4) count = c.size() / 4 + 1;
        for (std::size_t i = first; i < first + count; ++i) {
            for (const double g : gammas) s += g17(cdklm(c[i], g)) + "\n";
        }
        return s;
    }
    PhotometricFile read() const { return read_eulumdat(text(), "test.ldt"); }
};

/// The 1-based line of `text` that holds `needle` first.
std::size_t line_of(const std::string& text, const std::string& needle) {
    const std::size_t at = text.find(needle);
    EXPECT_NE(at, std::string::npos) << needle;
    return static_cast<std::size_t>(std::count(text.begin(), text.begin() + at, '\n')) + 1;
}

/// Directions spread over the sphere (a Fibonacci lattice).
std::vector<glm::dvec3> sphere_directions(int n) {
    std::vector<glm::dvec3> d;
    const double golden = kPi * (3.0 - std::sqrt(5.0));
    for (int i = 0; i < n; ++i) {
        const double z = 1.0 - (2.0 * i + 1.0) / n;
        const double r = std::sqrt(1.0 - z * z);
        d.push_back({r * std::cos(golden * i), r * std::sin(golden * i), z});
    }
    return d;
}

// ---------------------------------------------------------------------------------------------
// Fluxes against closed forms

TEST(Photometry, UniformSphereFluxIsFourPiI) {
    Ies ies;
    ies.vertical = range(0.0, 180.0, 22.5);
    ies.horizontal = range(0.0, 360.0, 30.0);
    ies.cd = [](double, double) { return 250.0; };
    const PhotometricFile f = ies.read();
    EXPECT_NEAR(f.flux(), 4.0 * kPi * 250.0, 1e-9 * 4.0 * kPi * 250.0);
    EXPECT_NEAR(f.web.intensity(glm::dvec3(0.6, 0.0, 0.8)), 250.0, 1e-9);
}

TEST(Photometry, CosineLowerHemisphereFluxIsPiI0) {
    for (const double step : {1.0, 2.5, 5.0}) {
        Ies ies;
        ies.vertical = range(0.0, 90.0, step);
        ies.cd = [](double, double g) { return 1000.0 * std::cos(g * kRad); };
        const PhotometricFile f = ies.read();
        EXPECT_NEAR(f.flux(), kPi * 1000.0, 1e-3 * kPi * 1000.0) << "step " << step;
        // Dark above the horizon
        EXPECT_EQ(f.web.intensity(glm::dvec3(0.0, 0.6, 0.8)), 0.0);
    }
}

TEST(Photometry, CosineTypeBWebFluxIsPiI0) {
    // I = I0 cos V cos H = I0 (-d.z): a Lambertian lower hemisphere in B's own angles
    Ies ies;
    ies.type = 2;
    ies.horizontal = range(-90.0, 90.0, 2.5);
    ies.vertical = range(-90.0, 90.0, 2.5);
    ies.cd = [](double h, double v) { return 500.0 * std::cos(v * kRad) * std::cos(h * kRad); };
    const PhotometricFile f = ies.read();
    EXPECT_NEAR(f.flux(), kPi * 500.0, 1e-3 * kPi * 500.0);
    for (const glm::dvec3& d : sphere_directions(200)) {
        EXPECT_NEAR(f.web.intensity(d), d.z < 0.0 ? -500.0 * d.z : 0.0, 0.5) << d.x << " " << d.y;
    }
}

TEST(Photometry, TypeAAndBHalfWebsMirrorToAHemisphere) {
    for (const int type : {2, 3}) {
        Ies ies;
        ies.type = type;
        ies.horizontal = range(0.0, 90.0, 15.0);
        ies.vertical = range(0.0, 90.0, 15.0);
        ies.cd = [](double, double) { return 40.0; };
        const PhotometricFile f = ies.read();
        EXPECT_EQ(f.web.horizontal.front(), -90.0);
        EXPECT_EQ(f.web.vertical.front(), -90.0);
        EXPECT_NEAR(f.flux(), 2.0 * kPi * 40.0, 1e-9) << "type " << type;
        EXPECT_NEAR(f.web.intensity(glm::dvec3(0.3, -0.4, -0.866)), 40.0, 1e-9);
        EXPECT_EQ(f.web.intensity(glm::dvec3(0.3, -0.4, 0.866)), 0.0);
    }
}

TEST(Photometry, TypeBFullSphereFluxIsFourPiI) {
    Ies ies;
    ies.type = 2;
    ies.horizontal = range(-180.0, 180.0, 20.0);
    ies.vertical = range(-90.0, 90.0, 10.0);
    ies.cd = [](double, double) { return 7.0; };
    EXPECT_NEAR(ies.read().flux(), 4.0 * kPi * 7.0, 1e-9);
}

// ---------------------------------------------------------------------------------------------
// Frames and symmetries

TEST(Photometry, DirectionsAndAnglesAreInverse) {
    for (const auto type : {PhotometricType::C, PhotometricType::B, PhotometricType::A}) {
        PhotometricWeb web;
        web.type = type;
        for (const glm::dvec3& d : sphere_directions(50)) {
            const auto [h, v] = web.angles(d);
            const glm::dvec3 back = web.direction(h, v);
            EXPECT_NEAR(back.x, d.x, 1e-12);
            EXPECT_NEAR(back.y, d.y, 1e-12);
            EXPECT_NEAR(back.z, d.z, 1e-12);
        }
    }
    // Nadir is γ = 0 (type C) and H = V = 0 (types A, B); C = 90 and B's V = 90 point to +y
    PhotometricWeb c;
    EXPECT_NEAR(glm::length(c.direction(0.0, 0.0) - glm::dvec3(0, 0, -1)), 0.0, 1e-15);
    EXPECT_NEAR(glm::length(c.direction(90.0, 90.0) - glm::dvec3(0, 1, 0)), 0.0, 1e-15);
    PhotometricWeb b;
    b.type = PhotometricType::B;
    EXPECT_NEAR(glm::length(b.direction(0.0, 90.0) - glm::dvec3(0, 1, 0)), 0.0, 1e-15);
    EXPECT_NEAR(glm::length(b.direction(90.0, 0.0) - glm::dvec3(1, 0, 0)), 0.0, 1e-15);
}

/// A quadrant-symmetric web: I(C, γ) = 100 + 40 cos 2C sin γ. Its flux is 400π (cos 2C
/// integrates to zero, also under the trapezoid rule over whole periods).
double quadrant_web(double c, double g) {
    return 100.0 + 40.0 * std::cos(2.0 * c * kRad) * std::sin(g * kRad);
}

TEST(Photometry, TypeCSymmetriesUnfoldToTheSameWeb) {
    Ies full;
    full.vertical = range(0.0, 180.0, 15.0);
    full.horizontal = range(0.0, 360.0, 15.0);
    full.cd = quadrant_web;
    const PhotometricFile reference = full.read();
    EXPECT_NEAR(reference.flux(), 400.0 * kPi, 1e-9 * 400.0 * kPi);
    for (const auto& [first, last] :
         std::vector<std::pair<double, double>>{{0.0, 90.0}, {0.0, 180.0}, {90.0, 270.0}}) {
        Ies part = full;
        part.horizontal = range(first, last, 15.0);
        const PhotometricFile f = part.read();
        EXPECT_EQ(f.web.horizontal, reference.web.horizontal) << first << ".." << last;
        ASSERT_EQ(f.web.candela.size(), reference.web.candela.size());
        for (std::size_t i = 0; i < f.web.candela.size(); ++i) {
            EXPECT_NEAR(f.web.candela[i], reference.web.candela[i], 1e-9) << i;
        }
        EXPECT_NEAR(f.flux(), reference.flux(), 1e-9);
    }
}

TEST(Photometry, AsymmetricWebKeepsItsPlanes) {
    Ies ies;
    ies.horizontal = range(0.0, 360.0, 45.0);
    ies.vertical = range(0.0, 180.0, 45.0);
    ies.cd = [](double c, double) { return c == 360.0 ? 0.0 : c; };  // 0 at C0 = C360
    const PhotometricFile f = ies.read();
    EXPECT_NEAR(f.web.intensity(90.0, 45.0), 90.0, 1e-12);
    EXPECT_NEAR(f.web.intensity(112.5, 30.0), 112.5, 1e-12);  // bilinear between planes
    EXPECT_NEAR(f.web.intensity(-45.0, 60.0), 315.0, 1e-12);  // modulo 360
    // C = 90 points to +y (counter-clockwise seen from above)
    EXPECT_NEAR(f.web.intensity(glm::dvec3(0.0, 0.7071067811865476, -0.7071067811865476)), 90.0,
                1e-9);
}

TEST(Photometry, BilinearBetweenSamples) {
    Ies ies;
    ies.horizontal = range(0.0, 360.0, 90.0);
    ies.vertical = range(0.0, 180.0, 90.0);
    // I = C + 2γ: bilinear reproduces it exactly inside the grid
    ies.cd = [](double c, double g) { return c == 360.0 ? 2.0 * g : c + 2.0 * g; };
    const PhotometricFile f = ies.read();
    EXPECT_NEAR(f.web.intensity(33.0, 71.0), 33.0 + 142.0, 1e-9);
    EXPECT_NEAR(f.web.intensity(200.0, 100.0), 200.0 + 200.0, 1e-9);
}

// ---------------------------------------------------------------------------------------------
// Every version, TILT, factors, openings

TEST(Photometry, EveryVersionParses) {
    const std::vector<std::pair<std::string, std::string>> versions = {
        {"", "LM-63-1986"},
        {"IESNA91", "LM-63-1991"},
        {"IESNA:LM-63-1995", "LM-63-1995"},
        {"IESNA:LM-63-2002", "LM-63-2002"},
        {"IES:LM-63-2019", "LM-63-2019"}};
    for (const auto& [line, version] : versions) {
        Ies ies;
        ies.version = line;
        const PhotometricFile f = ies.read();
        EXPECT_EQ(f.version, version);
        EXPECT_EQ(f.format, "ies");
        EXPECT_EQ(f.description, "Abrad Lighting, Test web");
    }
}

TEST(Photometry, MultiplierAndBallastFactorsScaleTheCandela) {
    Ies ies;
    ies.multiplier = 2.0;
    ies.ballast = 0.9;
    ies.third = 0.5;  // 2002: future use, not applied
    const PhotometricFile f2002 = ies.read();
    EXPECT_NEAR(f2002.web.intensity(0.0, 30.0), 100.0 * 2.0 * 0.9, 1e-12);
    EXPECT_NEAR(f2002.lamp_lumens, 1000.0 * 2.0 * 0.9, 1e-9);
    ies.version = "IESNA:LM-63-1995";  // 1995: the ballast-lamp photometric factor applies
    const PhotometricFile f1995 = ies.read();
    EXPECT_NEAR(f1995.web.intensity(0.0, 30.0), 100.0 * 2.0 * 0.9 * 0.5, 1e-12);
    // Lamps and lumens: the flux report compares the web with them
    ies.version = "IES:LM-63-2019";
    ies.third = 1.0;
    ies.multiplier = 1.0;
    ies.ballast = 1.0;
    ies.lamps = "2";
    ies.cd = [](double, double g) { return 1000.0 * std::cos(g * kRad); };
    ies.vertical = range(0.0, 90.0, 1.0);
    const PhotometricFile f = ies.read();
    EXPECT_EQ(f.lamp_lumens, 2000.0);
    EXPECT_NE(f.flux_report().find("LOR 1.571"), std::string::npos) << f.flux_report();
    ies.lumens = -1.0;  // absolute photometry
    EXPECT_EQ(ies.read().lamp_lumens, 0.0);
    EXPECT_NE(ies.read().flux_report().find("absolute photometry"), std::string::npos);
}

TEST(Photometry, TiltIncludeIsRead) {
    Ies ies;
    ies.tilt = "TILT=INCLUDE";
    ies.tilt_data = "1\n7\n0 15 30 45 60 75 90\n1.0 0.95 0.94 0.90 0.88 0.87 0.94\n";
    const PhotometricFile f = ies.read();
    EXPECT_EQ(f.tilt_geometry, 1);
    EXPECT_EQ(f.tilt_angles.size(), 7U);
    EXPECT_EQ(f.tilt_factors[3], 0.90);
    EXPECT_NEAR(f.web.intensity(0.0, 0.0), 100.0, 1e-12);
}

TEST(Photometry, OpeningShapesFromSigns) {
    using S = LuminousOpening::Shape;
    struct Case {
        double w, l, h;
        S shape;
    };
    const std::vector<Case> cases = {{0, 0, 0, S::Point},
                                     {0.3, 1.2, 0, S::Rectangle},
                                     {0.3, 1.2, 0.1, S::Box},
                                     {-0.2, -0.2, 0, S::Disc},
                                     {-0.2, -0.3, 0, S::Disc},
                                     {-0.2, -0.2, 0.4, S::VerticalCylinder},
                                     {-0.2, -0.2, -0.2, S::Sphere},
                                     {-0.1, 1.5, -0.1, S::CylinderAlongX},
                                     {1.5, -0.1, -0.1, S::CylinderAlongY},
                                     {-0.2, 0, -0.2, S::VerticalDiscFacingX},
                                     {0, -0.2, -0.2, S::VerticalDiscFacingY},
                                     {-0.25, 0, 0, S::Disc}};
    for (const Case& c : cases) {
        Ies ies;
        ies.width = c.w;
        ies.length = c.l;
        ies.height = c.h;
        const PhotometricFile f = ies.read();
        EXPECT_EQ(f.opening.shape, c.shape) << c.w << " " << c.l << " " << c.h;
        EXPECT_EQ(f.opening.width, std::abs(c.w));
        EXPECT_EQ(f.opening.height, std::abs(c.h));
    }
    // Feet
    Ies feet;
    feet.units = 1;
    feet.width = 1.0;
    feet.length = 4.0;
    const PhotometricFile f = feet.read();
    EXPECT_NEAR(f.opening.width, 0.3048, 1e-15);
    EXPECT_NEAR(f.opening.length, 1.2192, 1e-15);
}

TEST(Photometry, CommaSeparatedAndCrlfFilesParse) {
    Ies ies;
    std::string text = ies.text();
    std::string crlf;
    for (const char c : text) {
        if (c == '\n') crlf += '\r';
        crlf += c;
    }
    EXPECT_NEAR(read_ies(crlf, "crlf.ies").web.intensity(0.0, 45.0), 100.0, 1e-12);
    const std::size_t at = text.find("0 10 20");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, 7, "0,10,20");
    EXPECT_NEAR(read_ies(text, "commas.ies").web.intensity(0.0, 45.0), 100.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// EULUMDAT

TEST(Photometry, EulumdatEverySymmetryGivesTheSameWeb) {
    Ies ies;  // the same web as an IES file: C every 15°, γ every 5° to 180
    ies.horizontal = range(0.0, 360.0, 15.0);
    ies.vertical = range(0.0, 180.0, 5.0);
    ies.cd = [](double c, double g) { return 2.0 * quadrant_web(c, g); };  // 2000 lm lamps
    const PhotometricFile reference = ies.read();
    for (const int isym : {0, 2, 3, 4}) {
        Ldt ldt;
        ldt.isym = isym;
        ldt.cdklm = quadrant_web;
        const PhotometricFile f = ldt.read();
        EXPECT_EQ(f.version, "EULUMDAT");
        EXPECT_EQ(f.web.horizontal, reference.web.horizontal) << "Isym " << isym;
        ASSERT_EQ(f.web.candela.size(), reference.web.candela.size());
        for (std::size_t i = 0; i < f.web.candela.size(); ++i) {
            EXPECT_NEAR(f.web.candela[i], reference.web.candela[i], 1e-9) << i;
        }
        EXPECT_NEAR(f.flux(), 2.0 * 400.0 * kPi, 1e-9 * 800.0 * kPi);
    }
}

TEST(Photometry, EulumdatRotationalSymmetryAndFlux) {
    Ldt ldt;
    ldt.isym = 1;
    ldt.gammas = range(0.0, 90.0, 2.5);
    ldt.lamp_flux = 3000.0;
    ldt.lorl = 100.0;
    ldt.area_width = 0.0;  // a disc of 600 mm
    ldt.cdklm = [](double, double g) { return 1000.0 / kPi * std::cos(g * kRad); };
    const PhotometricFile f = ldt.read();
    EXPECT_TRUE(f.web.rotationally_symmetric());
    // Lambertian: Φ = π I0 = the lamps' 3000 lm
    EXPECT_NEAR(f.flux(), 3000.0, 3e-4 * 3000.0);
    EXPECT_EQ(f.lamp_lumens, 3000.0);
    EXPECT_EQ(f.stated_lor, 1.0);
    EXPECT_EQ(f.opening.shape, LuminousOpening::Shape::Disc);
    EXPECT_NEAR(f.opening.width, 0.6, 1e-15);
    EXPECT_NE(f.flux_report().find("LOR 1.000 (file states 1.000)"), std::string::npos)
        << f.flux_report();
}

TEST(Photometry, EulumdatDecimalCommasAndOpening) {
    Ldt ldt;
    std::string text = ldt.text();
    const std::size_t at = text.find("\n0.5\n");
    text.replace(at, 5, "\n0,5\n");
    const PhotometricFile f = read_eulumdat(text, "comma.ldt");
    EXPECT_EQ(f.opening.shape, LuminousOpening::Shape::Rectangle);
    EXPECT_NEAR(f.opening.length, 0.6, 1e-15);
    EXPECT_NEAR(f.opening.width, 0.3, 1e-15);
}

// ---------------------------------------------------------------------------------------------
// Malformed files: refused at their line, naming the field

/// A malformed file: its text, the line and the words of the field its error must name.
struct Malformed {
    std::string label;
    std::string text;
    std::size_t line;
    std::string field;
};

/// Expects `parse` to throw an ImportError at `line` whose message holds `field`.
template <class Parse>
void expect_refused(Parse parse, std::size_t line, const std::string& field,
                    const std::string& label) {
    try {
        parse();
        ADD_FAILURE() << label << ": accepted";
    } catch (const ImportError& e) {
        EXPECT_EQ(e.line(), line) << label << ": " << e.what();
        EXPECT_NE(std::string(e.what()).find(field), std::string::npos)
            << label << ": " << e.what();
        EXPECT_EQ(std::string(e.what()).rfind(e.file() + ":", 0), 0U) << e.what();
    }
}

/// `text` with the first `from` after `after` replaced by `to`.
std::string replaced(std::string text, const std::string& after, const std::string& from,
                     const std::string& to) {
    const std::size_t start = text.find(after);
    EXPECT_NE(start, std::string::npos) << after;
    const std::size_t at = text.find(from, start);
    EXPECT_NE(at, std::string::npos) << from;
    return text.replace(at, from.size(), to);
}

TEST(Photometry, MalformedIesFilesAreRefused) {
    Ies ies;
    ies.horizontal = {0.0, 90.0};
    const std::string good = ies.text();
    const std::size_t lum = line_of(good, "1 1000 1 10 2");
    const std::size_t last = line_of(good, "\n100 100") + 2;  // the second candela line
    const std::vector<Malformed> cases = {
        {"empty", "", 0, "empty file"},
        {"no TILT", replaced(good, "", "TILT=NONE", "TALT=NONE"), line_of(good, "90 \n100") + 2,
         "TILT"},
        {"tilt file", replaced(good, "", "TILT=NONE", "TILT=lamp.tlt"), line_of(good, "TILT"),
         "TILT"},
        {"truncated candela", good.substr(0, good.rfind("100 ")), last, "candela at horizontal 90"},
        {"negative candela", replaced(good, "\n100", "100", "-5"), lum + 4,
         "must be a number >= 0"},
        {"NaN candela", replaced(good, "\n100", "100", "nan"), lum + 4,
         "a finite number, got 'nan'"},
        {"junk candela", replaced(good, "\n100", "100", "1O0"), lum + 4, "candela at horizontal 0"},
        {"too many candela", good + "100\n", last + 1, "counts do not match"},
        {"vertical count too large", replaced(good, "", "1 1000 1 10 2", "1 1000 1 11 2"), lum + 3,
         "vertical angle 11 of 11"},
        {"zero lamps", replaced(good, "", "1 1000 1 10 2", "0 1000 1 10 2"), lum,
         "number of lamps"},
        {"fractional count", replaced(good, "", "1 1000 1 10 2", "1 1000 1 10.5 2"), lum,
         "number of vertical angles"},
        {"zero lumens", replaced(good, "", "1 1000 1 10 2", "1 0 1 10 2"), lum, "lumens per lamp"},
        {"zero multiplier", replaced(good, "", "1 1000 1 10 2", "1 1000 0 10 2"), lum,
         "candela multiplier"},
        {"photometric type 4", replaced(good, "", "10 2 1 2", "10 2 4 2"), lum, "photometric type"},
        {"units type 3", replaced(good, "", "10 2 1 2", "10 2 1 3"), lum, "units type"},
        {"opening signs", replaced(good, "", "1 2 0 0 0", "1 2 1 -1 1"), lum, "luminous opening"},
        {"zero ballast", replaced(good, "", "\n1 1 20", "\n0 1 20"), lum + 1, "ballast factor"},
        {"angles out of order", replaced(good, "", "0 10 20", "0 20 10"), lum + 2,
         "vertical angle 3 of 10"},
        {"vertical beyond 180", replaced(good, "", " 90 \n0 90", " 190 \n0 90"), lum + 2,
         "vertical angle 10 of 10"},
        {"horizontal 0..270", replaced(good, "", "\n0 90 \n", "\n0 270 \n"), lum + 3,
         "horizontal angles: type C angles must run"},
    };
    for (const Malformed& c : cases) {
        expect_refused([&] { return read_ies(c.text, "bad.ies"); }, c.line, c.field, c.label);
    }
    // A truncated tilt table
    Ies tilt;
    tilt.tilt = "TILT=INCLUDE";
    tilt.tilt_data = "1\n3\n0 45 90\n1.0 0.9\n";
    const std::string cut = tilt.text().substr(0, tilt.text().find("1.0 0.9") + 7);
    expect_refused([&] { return read_ies(cut, "bad.ies"); }, line_of(cut, "1.0 0.9"),
                   "tilt multiplying factor 3 of 3", "truncated tilt table");
}

TEST(Photometry, MalformedEulumdatFilesAreRefused) {
    Ldt ldt;
    ldt.isym = 4;
    const std::string good = ldt.text();
    const auto line_n = [&](std::size_t n) {  // the text with line n (1-based) replaced
        return [&good, n](const std::string& value) {
            std::string t = good;
            std::size_t start = 0;
            for (std::size_t i = 1; i < n; ++i) start = t.find('\n', start) + 1;
            return t.replace(start, t.find('\n', start) - start, value);
        };
    };
    const std::size_t lines = static_cast<std::size_t>(std::count(good.begin(), good.end(), '\n'));
    const std::vector<Malformed> cases = {
        {"empty", "", 0, "empty file"},
        {"Isym 5", line_n(3)("5"), 3, "symmetry indicator Isym"},
        {"Mc odd for Isym 4", line_n(4)("23"), 4, "number of C-planes Mc"},
        {"Ng 1", line_n(6)("1"), 6, "number of gamma angles Ng"},
        {"LORL 120", line_n(23)("120"), 23, "light output ratio LORL"},
        {"lamp flux 0", line_n(29)("0"), 29, "total luminous flux of lamps (lm), set 1"},
        {"negative intensity", line_n(lines)("-1"), lines, "luminous intensity at C 90, gamma 180"},
        {"NaN intensity", line_n(lines)("NaN"), lines, "a finite number"},
        {"truncated", good.substr(0, good.size() - 4), lines - 1, "luminous intensity at C 90"},
        {"trailing data", good + "7\n", lines + 1, "counts do not match"},
        {"C angles out of order", line_n(44)("0"), 44, "C angle 2 of 24"},
        {"gamma beyond 180", line_n(42 + 24 + 37)("190"), 42 + 24 + 37, "gamma angle 37 of 37"},
    };
    for (const Malformed& c : cases) {
        expect_refused([&] { return read_eulumdat(c.text, "bad.ldt"); }, c.line, c.field, c.label);
    }
    // Isym 2 needs the plane C180 at index Mc/2: a C-plane list that misses it
    Ldt odd;
    odd.isym = 2;
    std::string t = odd.text();
    t = replaced(t, "\n165\n", "\n180\n", "\n181\n");
    expect_refused([&] { return read_eulumdat(t, "bad.ldt"); }, 55,
                   "C angles: symmetry indicator 2", "Isym 2 without C180");
}

TEST(Photometry, FilesAreReadByExtension) {
    const ::abrad::testing::TempDir dir;
    Ies ies;
    Ldt ldt;
    const auto ies_path = dir.write("lamp.IES", ies.text());
    const auto ldt_path = dir.write("lamp.ldt", ldt.text());
    EXPECT_EQ(read_photometric_file(ies_path).format, "ies");
    EXPECT_EQ(read_photometric_file(ldt_path).format, "ldt");
    EXPECT_EQ(read_photometric_file(ies_path).path, ies_path.string());
    expect_refused([&] { return read_photometric_file(dir / "missing.ies"); }, 0,
                   "no such photometric file", "missing");
    const auto txt = dir.write("lamp.txt", ies.text());
    expect_refused([&] { return read_photometric_file(txt); }, 0, "extension must be .ies",
                   "extension");
}

}  // namespace
}  // namespace abrad::convert
