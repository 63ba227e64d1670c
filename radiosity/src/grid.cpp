// Calculation grids and probe points: see grid.h.

#include "abrad/radiosity/grid.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <glm/geometric.hpp>
#include <numeric>
#include <sstream>

#include "abrad/atomic_file.h"

namespace abrad::radiosity {

double luminance(const visdb::Rgb& h) { return visdb::luminance(h); }

std::vector<double> GridValues::image() const {
    std::vector<double> out(value.size());
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
            out[std::size_t(j) * std::size_t(nx) + std::size_t(i)] =
                value[std::size_t(ny - 1 - j) * std::size_t(nx) + std::size_t(i)];
    return out;
}

GridValues grid_points(const visdb::CalculationGrid& g) {
    GridValues out;
    out.nx = std::max(1, static_cast<int>(std::ceil((g.max.x - g.min.x) / g.spacing - 1e-9)));
    out.ny = std::max(1, static_cast<int>(std::ceil((g.max.y - g.min.y) / g.spacing - 1e-9)));
    for (int j = 0; j < out.ny; ++j)
        for (int i = 0; i < out.nx; ++i)
            out.points.push_back({{g.min.x + (i + 0.5) * (g.max.x - g.min.x) / out.nx,
                                   g.min.y + (j + 0.5) * (g.max.y - g.min.y) / out.ny, g.z},
                                  g.normal});
    return out;
}

GridValues evaluate_grid(const PointIrradiance& field, const visdb::CalculationGrid& grid) {
    GridValues out = grid_points(grid);
    out.irradiance = field.at(out.points);
    out.value.resize(out.irradiance.size());
    std::transform(out.irradiance.begin(), out.irradiance.end(), out.value.begin(), luminance);
    if (!out.value.empty()) {
        out.e_min = *std::min_element(out.value.begin(), out.value.end());
        out.e_max = *std::max_element(out.value.begin(), out.value.end());
        out.e_avg = std::accumulate(out.value.begin(), out.value.end(), 0.0) /
                    static_cast<double>(out.value.size());
    }
    return out;
}

void write_grid_csv(const std::filesystem::path& path, const GridValues& grid) {
    std::ostringstream out;
    out << "x,y,z,illuminance,irradiance_r,irradiance_g,irradiance_b\n";
    out.precision(9);
    for (std::size_t k = 0; k < grid.points.size(); ++k) {
        const glm::dvec3& x = grid.points[k].x;
        const visdb::Rgb& h = grid.irradiance[k];
        out << x.x << "," << x.y << "," << x.z << "," << grid.value[k] << "," << h.x << "," << h.y
            << "," << h.z << "\n";
    }
    write_file_atomically(path, out.view());
}

namespace {

// Parses "a,b,c,d,e,f" (blanks around the numbers allowed) into v; false when malformed.
bool parse_six(const std::string& line, double (&v)[6]) {
    int count = 0;
    const char* p = line.data();
    const char* end = line.data() + line.size();
    bool ok = true;
    while (ok && p < end) {
        while (p < end && (*p == ' ' || *p == '\t')) ++p;
        const auto [next, ec] = std::from_chars(p, end, count < 6 ? v[count] : v[5]);
        ok = ec == std::errc() && count < 6 && std::isfinite(v[count]);
        p = next;
        ++count;
        while (p < end && (*p == ' ' || *p == '\t')) ++p;
        if (p < end) ok = ok && *p++ == ',';
    }
    return ok && count == 6;
}

}  // namespace

std::vector<ProbePoint> read_probe_points(const std::filesystem::path& path) {
    const std::string name = path.string();
    std::ifstream in(path);
    if (!in) throw InputFileError(name + ": cannot open points file");
    std::vector<ProbePoint> points;
    std::string line;
    for (std::size_t number = 1; std::getline(in, line); ++number) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.find_first_not_of(" \t") == std::string::npos) continue;
        double v[6];
        if (!parse_six(line, v)) {
            // A header: the first line, without any digit (a malformed first row is an error)
            if (number == 1 && line.find_first_of("0123456789") == std::string::npos) continue;
            throw InputFileError(name + ":" + std::to_string(number) +
                                 ": expected six finite numbers x,y,z,nx,ny,nz");
        }
        const glm::dvec3 n(v[3], v[4], v[5]);
        if (!(glm::length(n) > 0.0))
            throw InputFileError(name + ":" + std::to_string(number) + ": normal is zero");
        points.push_back({{v[0], v[1], v[2]}, glm::normalize(n)});
    }
    if (points.empty()) throw InputFileError(name + ": no points");
    return points;
}

}  // namespace abrad::radiosity
