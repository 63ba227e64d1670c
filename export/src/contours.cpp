// Marching squares (Lorensen & Cline, "Marching cubes", SIGGRAPH 1987, in two dimensions) and
// round contour levels (export/include/abrad/export/contours.h).

#include "abrad/export/contours.h"

#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>

namespace abrad::exporter {

std::string IsoSegment::to_string() const {
    // Appended piece by piece ("(" + std::string made GCC 12 warn -Wrestrict at -O3)
    std::string out = "(";
    out += std::to_string(a.i);
    out += ' ';
    out += std::to_string(a.j);
    out += ")-(";
    out += std::to_string(b.i);
    out += ' ';
    out += std::to_string(b.j);
    out += ')';
    return out;
}

namespace {

// The crossing of `level` on the lattice edge from p (value vp) to q (value vq), whose values
// lie on either side of it
LatticePoint crossing(LatticePoint p, double vp, LatticePoint q, double vq, double level) {
    const double t = (level - vp) / (vq - vp);
    return {p.i + t * (q.i - p.i), p.j + t * (q.j - p.j)};
}

// The segments of one cell with corners c[0..3] = (i, j), (i+1, j), (i+1, j+1), (i, j+1)
// (counter-clockwise) and their values v
void march_cell(const std::array<LatticePoint, 4>& c, const std::array<double, 4>& v, double level,
                std::vector<IsoSegment>& out) {
    // Which corners are above (a value equal to the level counts as above)
    std::array<bool, 4> above{};
    int count = 0;
    for (std::size_t k = 0; k < 4; ++k) {
        above[k] = v[k] >= level;
        count += above[k] ? 1 : 0;
    }
    if (count == 0 || count == 4) return;
    // The crossings on the edges k -> k+1 whose ends differ, in counter-clockwise order
    std::array<LatticePoint, 4> x{};
    std::array<std::size_t, 4> edge{};
    std::size_t n = 0;
    for (std::size_t k = 0; k < 4; ++k) {
        const std::size_t l = (k + 1) % 4;
        if (above[k] != above[l]) {
            x[n] = crossing(c[k], v[k], c[l], v[l], level);
            edge[n++] = k;
        }
    }
    if (n == 2) {
        out.push_back({x[0], x[1]});
        return;
    }
    // A saddle (four crossings): the mean of the corners decides whether the above corners
    // connect through the centre; the pairs are then the crossings around each below corner
    // (centre above) or around each above corner (centre below)
    const double centre = 0.25 * (v[0] + v[1] + v[2] + v[3]);
    const bool centre_above = centre >= level;
    // Crossing m follows corner edge[m]; corner edge[m]+1 lies between crossings m and m+1
    const bool first_pair_around_above = above[(edge[0] + 1) % 4];
    if (first_pair_around_above != centre_above) {
        out.push_back({x[0], x[1]});
        out.push_back({x[2], x[3]});
    } else {
        out.push_back({x[1], x[2]});
        out.push_back({x[3], x[0]});
    }
}

}  // namespace

std::vector<IsoSegment> isoline(std::span<const double> values, int nx, int ny, double level) {
    if (nx < 0 || ny < 0 ||
        values.size() != static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny))
        throw std::invalid_argument("isoline: " + std::to_string(values.size()) +
                                    " values for a lattice of " + std::to_string(nx) + " x " +
                                    std::to_string(ny));
    std::vector<IsoSegment> out;
    const auto at = [&](int i, int j) {
        return values[static_cast<std::size_t>(j) * static_cast<std::size_t>(nx) +
                      static_cast<std::size_t>(i)];
    };
    for (int j = 0; j + 1 < ny; ++j) {
        for (int i = 0; i + 1 < nx; ++i) {
            const std::array<double, 4> v{at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)};
            if (std::isnan(v[0]) || std::isnan(v[1]) || std::isnan(v[2]) || std::isnan(v[3]))
                continue;
            const double fi = i;
            const double fj = j;
            march_cell({LatticePoint{fi, fj}, {fi + 1.0, fj}, {fi + 1.0, fj + 1.0}, {fi, fj + 1.0}},
                       v, level, out);
        }
    }
    return out;
}

std::vector<double> contour_levels(double lo, double hi, int max_count) {
    std::vector<double> best;
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(hi > lo) || max_count < 1) return best;
    // Try the round steps from coarse to fine; keep the finest that gives at most max_count
    const double top = std::pow(10.0, std::ceil(std::log10(hi - lo)));
    for (double decade = top; decade > top * 1e-3; decade /= 10.0) {
        for (const double s : {5.0, 2.5, 2.0, 1.0}) {
            const double step = s * decade / 10.0;
            std::vector<double> levels;
            // k · step strictly inside (lo, hi), with a margin for the rounding of lo / step
            const double margin = 1e-9 * step;
            for (double k = std::floor(lo / step); k * step < hi - margin; k += 1.0) {
                if (k * step <= lo + margin) continue;
                levels.push_back(k * step);
                if (static_cast<int>(levels.size()) > max_count) break;
            }
            if (static_cast<int>(levels.size()) > max_count) return best;
            if (levels.size() > best.size()) best = std::move(levels);
        }
    }
    return best;
}

}  // namespace abrad::exporter
