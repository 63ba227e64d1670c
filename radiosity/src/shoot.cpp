// A-buffer hemicube shooting: Wang, Tang, Lim, Teh & Huang, "Using A-Buffer in Radiosity";
// coverage masks after Carpenter, "The A-buffer, an antialiased hidden surface method" (1984).
//
// Numeric assumptions. Clipping against the face frusta uses plane tests that are exact
// negations of each other on neighbouring faces, so a triangle straddling two faces is split
// into pieces that partition it (intersection points are constructed in double precision).
// Sample coverage uses a half-open rule in x and y, so two triangles sharing an edge never
// both cover a sample.

#include "abrad/radiosity/shoot.h"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <glm/vec4.hpp>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "abrad/check.h"
#include "abrad/hash.h"
#include "abrad/radiosity/polygon.h"

namespace abrad::radiosity {

namespace {

// ---------------------------------------------------------------------------------------
// Coverage masks: S×S samples, row k in bits [k·S, k·S + S) of a run of 64-bit words.

template <int S>
struct Mask {
    static constexpr int kSide = S;
    static constexpr int kWords = (S * S + 63) / 64;
    static constexpr int kSamples = S * S;
    std::uint64_t w[kWords]{};

    static Mask full() {
        Mask m;
        for (int i = 0; i < kWords; ++i) w_set_all(m.w[i], i);
        return m;
    }
    static void w_set_all(std::uint64_t& word, int i) {
        const int bits = std::min(64, kSamples - i * 64);
        word = bits == 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << bits) - 1);
    }
    bool empty() const {
        for (int i = 0; i < kWords; ++i)
            if (w[i]) return false;
        return true;
    }
    // Word by word (std::equal on the words called memcmp for each fragment)
    bool operator==(const Mask& o) const {
        for (int i = 0; i < kWords; ++i)
            if (w[i] != o.w[i]) return false;
        return true;
    }
    int count() const {
        int c = 0;
        for (int i = 0; i < kWords; ++i) c += std::popcount(w[i]);
        return c;
    }
    // Sets samples [c0, c1) of row k.
    void set_row(int k, int c0, int c1) {
        if (c1 <= c0) return;
        const int bit = k * S + c0;
        const int n = c1 - c0;
        const std::uint64_t run = n == 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << n) - 1);
        w[bit / 64] |= run << (bit % 64);
    }
    void set(int k, int c) { set_row(k, c, c + 1); }
    bool test(int k, int c) const {
        const int bit = k * S + c;
        return (w[bit / 64] >> (bit % 64)) & 1u;
    }
    // The index k·S + c of the n-th set sample (n < count()): byte by byte, then bit by bit
    int nth(int n) const {
        for (int i = 0; i < kWords; ++i)
            for (int byte = 0; byte < 64; byte += 8) {
                auto bits = static_cast<unsigned>((w[i] >> byte) & 0xFFu);
                const int here = kBitsInByte[bits];
                if (n >= here) {
                    n -= here;
                    continue;
                }
                for (; n > 0; --n) bits &= bits - 1;  // drop the lowest set bits
                return i * 64 + byte + std::countr_zero(bits);
            }
        return -1;
    }
    static constexpr std::array<std::uint8_t, 256> kBitsInByte = [] {
        std::array<std::uint8_t, 256> t{};
        for (unsigned b = 0; b < 256; ++b)
            for (unsigned c = b; c != 0; c &= c - 1) ++t[b];
        return t;
    }();
    Mask operator&(const Mask& o) const {
        Mask r;
        for (int i = 0; i < kWords; ++i) r.w[i] = w[i] & o.w[i];
        return r;
    }
    Mask and_not(const Mask& o) const {
        Mask r;
        for (int i = 0; i < kWords; ++i) r.w[i] = w[i] & ~o.w[i];
        return r;
    }
};

// Each sample of an S mask becomes a 2×2 block of a 2S mask: a row's bits are spread (bit c to
// bits 2c and 2c + 1) a byte at a time and written to two rows. S divides 64, so no row of
// either mask straddles a word.
constexpr std::array<std::uint16_t, 256> kSpreadByte = [] {
    std::array<std::uint16_t, 256> t{};
    for (unsigned b = 0; b < 256; ++b)
        for (unsigned c = 0; c < 8; ++c)
            if ((b >> c) & 1u) t[b] = static_cast<std::uint16_t>(t[b] | (3u << (2 * c)));
    return t;
}();

template <int S>
Mask<2 * S> upsample(const Mask<S>& m) {
    static_assert(64 % S == 0 && 64 % (2 * S) == 0);
    constexpr std::uint64_t kRow = S == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << S) - 1;
    Mask<2 * S> r;
    for (int k = 0; k < S; ++k) {
        const int bit = k * S;
        const std::uint64_t row = (m.w[bit / 64] >> (bit % 64)) & kRow;
        if (row == 0) continue;
        std::uint64_t spread = 0;
        for (int b = 0; b < S; b += 8)
            spread |= std::uint64_t{kSpreadByte[(row >> b) & 0xFFu]} << (2 * b);
        for (const int fine_row : {2 * k, 2 * k + 1}) {
            const int fb = fine_row * 2 * S;
            r.w[fb / 64] |= spread << (fb % 64);
        }
    }
    return r;
}

// ---------------------------------------------------------------------------------------
// Scan conversion helpers on a convex polygon in pixel coordinates.

using Poly2 = FixedPolygon<glm::dvec2, 16>;

// Edge i of a polygon with its endpoints in a canonical order (lower y first, then lower x),
// so an edge shared by two polygons gives the same x in both.
struct Edge {
    const glm::dvec2* a;
    const glm::dvec2* b;
    Edge(const Poly2& p, std::size_t i) : a(&p[i]), b(&p[(i + 1) % p.size()]) {
        if (b->y < a->y || (b->y == a->y && b->x < a->x)) std::swap(a, b);
    }
    // Whether the edge spans height y (half-open: [a.y, b.y)), and its x there
    bool spans(double y) const { return a->y <= y && y < b->y; }
    double x_at(double y) const { return a->x + (y - a->y) * (b->x - a->x) / (b->y - a->y); }
};

// x-span [xl, xr) of a convex polygon on the line at height y (half-open in y at vertices).
bool span_at(const Poly2& p, double y, double& xl, double& xr) {
    xl = std::numeric_limits<double>::infinity();
    xr = -xl;
    for (std::size_t i = 0; i < p.size(); ++i) {
        const Edge e(p, i);
        if (e.spans(y)) {
            xl = std::min(xl, e.x_at(y));
            xr = std::max(xr, e.x_at(y));
        }
    }
    return xl < xr;
}

// The x-range of a convex polygon within the strip y0 <= y <= y1; false when it misses it.
bool strip_x_range(const Poly2& p, double y0, double y1, double& xmin, double& xmax) {
    xmin = std::numeric_limits<double>::infinity();
    xmax = -xmin;
    const std::size_t n = p.size();
    for (std::size_t i = 0; i < n; ++i) {
        const glm::dvec2& a = p[i];
        const glm::dvec2& b = p[(i + 1) % n];
        if (a.y >= y0 && a.y <= y1) {
            xmin = std::min(xmin, a.x);
            xmax = std::max(xmax, a.x);
        }
        // Where the edge crosses the strip's lines
        for (const double y : {y0, y1})
            if ((a.y < y && y < b.y) || (b.y < y && y < a.y)) {
                const double x = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
                xmin = std::min(xmin, x);
                xmax = std::max(xmax, x);
            }
    }
    return xmin < xmax;
}

// Lowest and highest y of a polygon.
std::pair<double, double> y_extent(const Poly2& p) {
    double lo = p[0].y, hi = p[0].y;
    for (const auto& v : p) {
        lo = std::min(lo, v.y);
        hi = std::max(hi, v.y);
    }
    return {lo, hi};
}

// Columns [c0, c1) of samples at positions base + (c + 0.5)/S·width... expressed in units of
// sample spacing: samples with centre s + 0.5 in [lo, hi).
inline void sample_range(double lo, double hi, int count, int& c0, int& c1) {
    c0 = static_cast<int>(std::clamp(std::ceil(lo - 0.5), 0.0, static_cast<double>(count)));
    c1 = static_cast<int>(std::clamp(std::ceil(hi - 0.5), 0.0, static_cast<double>(count)));
}

// Sample-row spans of a convex polygon over one pixel row strip [y0, y0 + 1], N rows. Sample
// g of a row (counted across the whole face, N per pixel) lies at x = (g + 0.5) / N and is
// covered when xl <= x < xr, so a row covers the samples [lo, hi): whole numbers, so that a
// pixel's mask, its sample count and its samples' centroid are integer arithmetic, and two
// polygons sharing an edge split its samples exactly (the same x for both, Edge).
template <int N>
struct RowSpans {
    long long lo[N]{}, hi[N]{};  // an empty row: lo = hi = 0
    // Pixel columns [full_lo, full_hi) are covered by every sample of the strip
    long long full_lo = 0, full_hi = 0;
    void compute(const Poly2& p, double y0) {
        double xl[N], xr[N];
        for (int k = 0; k < N; ++k) {
            xl[k] = std::numeric_limits<double>::infinity();
            xr[k] = -xl[k];
        }
        for (std::size_t i = 0; i < p.size(); ++i) {
            const Edge e(p, i);
            if (!(e.a->y < e.b->y) || e.b->y <= y0 || e.a->y >= y0 + 1.0) continue;
            for (int k = 0; k < N; ++k) {
                const double y = y0 + (k + 0.5) / N;
                if (e.spans(y)) {
                    xl[k] = std::min(xl[k], e.x_at(y));
                    xr[k] = std::max(xr[k], e.x_at(y));
                }
            }
        }
        full_lo = std::numeric_limits<long long>::min();
        full_hi = std::numeric_limits<long long>::max();
        for (int k = 0; k < N; ++k) {
            if (!(xl[k] < xr[k])) {
                lo[k] = hi[k] = 0;
                full_hi = full_lo;
                continue;
            }
            lo[k] = static_cast<long long>(std::ceil(xl[k] * N - 0.5));
            hi[k] = static_cast<long long>(std::ceil(xr[k] * N - 0.5));
            full_lo = std::max(full_lo, (lo[k] + N - 1) / N);  // lo >= 0 (clamped x)
            full_hi = std::min(full_hi, hi[k] / N);
        }
    }
    // Coverage mask of column [i, i+1]; `count` samples, whose positions sum to
    // (i + sum_x / (2N), y0 + sum_y / (2N)) times `count`.
    Mask<N> mask(int i, long long& count, long long& sum_x, long long& sum_y) const {
        Mask<N> m;
        count = sum_x = sum_y = 0;
        if (i >= full_lo && i < full_hi) {
            m = Mask<N>::full();
            count = static_cast<long long>(N) * N;
            sum_x = sum_y = count * N;  // every sample: centroid at the pixel's centre
            return m;
        }
        const long long base = static_cast<long long>(i) * N;
        for (int k = 0; k < N; ++k) {
            const int c0 =
                static_cast<int>(std::clamp(lo[k] - base, 0LL, static_cast<long long>(N)));
            const int c1 =
                static_cast<int>(std::clamp(hi[k] - base, 0LL, static_cast<long long>(N)));
            if (c1 > c0) {
                m.set_row(k, c0, c1);
                const long long n = c1 - c0;
                count += n;
                sum_x += n * (c0 + c1);
                sum_y += n * (2 * k + 1);
            }
        }
        return m;
    }
};

// The plane of a patch in face coordinates, for depth along a pixel's ray.
struct DepthPlane {
    glm::dvec3 normal;
    double offset;
    double fallback;  // depth used when the ray is parallel to the plane
    double depth(double a, double b) const {
        const double den = normal.x * a + normal.y * b + normal.z;
        if (std::abs(den) < 1e-300) return fallback;
        const double d = offset / den;
        return d > 0.0 ? d : fallback;
    }
};

// Targets' ids → local ids of one shot: open addressing, grown at half load.
class LocalIds {
  public:
    std::uint32_t id(std::uint32_t global, std::vector<std::uint32_t>& global_of) {
        if (2 * (global_of.size() + 1) > m_slots.size()) grow(global_of);
        const std::size_t mask = m_slots.size() - 1;
        for (std::size_t h = hash(global) & mask;; h = (h + 1) & mask) {
            std::uint32_t& slot = m_slots[h];
            if (slot == kNoPatch) {
                slot = static_cast<std::uint32_t>(global_of.size());
                global_of.push_back(global);
                return slot;
            }
            if (global_of[slot] == global) return slot;
        }
    }

    // Forgets every id, keeping the table's storage
    void clear() { std::fill(m_slots.begin(), m_slots.end(), kNoPatch); }

  private:
    void grow(const std::vector<std::uint32_t>& global_of) {
        m_slots.assign(std::max<std::size_t>(64, 2 * m_slots.size()), kNoPatch);
        const std::size_t mask = m_slots.size() - 1;
        for (std::uint32_t l = 0; l < global_of.size(); ++l) {
            std::size_t h = hash(global_of[l]) & mask;
            while (m_slots[h] != kNoPatch) h = (h + 1) & mask;
            m_slots[h] = l;
        }
    }
    static std::size_t hash(std::uint32_t x) { return std::size_t{x} * 0x9E3779B1u; }
    std::vector<std::uint32_t> m_slots;  // local ids, kNoPatch when empty
};

// A patch spanning several targets (Targets::grid), in the shooter's frame: the point l on its
// plane along a ray r is t·r with t = plane.w / (plane.xyz·r), and lies in the grid's cell
// (floor(i.xyz·l + i.w), floor(j.xyz·l + j.w)).
// The grid is found when a fragment first needs it (most patches' fragments are hidden).
struct Spread {
    glm::dvec4 plane{0.0}, i{0.0}, j{0.0};
    bool grid = false;
    void find_grid(const Targets& targets, std::uint32_t patch, const ShooterFrame& frame) {
        const Targets::Grid g = targets.grid(patch);
        const auto axis = [&](const glm::dvec3& w) {
            return glm::dvec4(glm::dot(w, frame.u), glm::dot(w, frame.v), glm::dot(w, frame.n),
                              glm::dot(frame.origin - g.origin, w)) /
                   g.size;
        };
        i = axis(g.u);
        j = axis(g.v);
        grid = true;
    }
};

template <int S>
struct Fragment {
    std::uint32_t pixel;
    std::uint32_t patch;  // local id: index into FragmentBuffer::patch_of
    // Local id of what takes its form factor (the patch, or a Targets'); kNoPatch for a patch
    // spanning several targets, whose fragments give to the cells their samples see
    std::uint32_t target;
    float depth;         // at its samples' centroid: the list's order
    std::uint32_t fine;  // index into the fine masks, or kNoPatch
    // The deepest its plane reaches over the pixel, where ClosedPixels closes the pixel (with
    // Targets: a fragment it keeps out may hide samples of one sorted before it)
    float far;
    Mask<S> mask;
};

// Everything one shot accumulates before propagation. Patches are numbered in the order they
// are visited (local ids), so nothing in a shot costs the size of the whole patch list.
template <int S>
struct FragmentBuffer {
    std::vector<Fragment<S>> fragments;
    std::vector<Mask<2 * S>> fine;
    std::vector<std::uint32_t> patch_of;  // local id → patch index
    std::vector<double> opacity;          // local id → opacity
    std::vector<char> partial;            // local id → a piece under a sample (partial_sample)
    // With Targets:
    std::vector<std::uint32_t> target_of;  // local target id → target
    LocalIds local_targets;                // target → local target id
    std::vector<Spread> spread_of;         // local id → its plane and grid (several targets)
    // Empties the buffer, keeping its storage for the thread's next shot
    void clear() {
        fragments.clear();
        fine.clear();
        patch_of.clear();
        opacity.clear();
        partial.clear();
        target_of.clear();
        local_targets.clear();
        spread_of.clear();
    }
};

// ---------------------------------------------------------------------------------------
// Rasterization of one clipped, projected patch piece onto one face.

template <int S>
class ClosedPixels;  // below: occlusion culling

// Without finer masks, a piece under a quarter of a sample's area: `coverage` (its area over
// a sample's) of sample (k, c) of `pixel`, through a local patch of its own whose opacity is
// the patch's times that coverage, marked partial (propagate adds up such pieces' coverages
// within a sample rather than stacking them); its form factor goes to the patch's target.
template <int S>
void partial_sample(std::uint32_t patch, std::size_t pixel, int k, int c, double coverage,
                    double depth, FragmentBuffer<S>& out) {
    Mask<S> one;
    one.set(k, c);
    const auto id = static_cast<std::uint32_t>(out.patch_of.size());
    out.patch_of.push_back(out.patch_of[patch]);
    out.opacity.push_back(out.opacity[patch] * coverage);
    out.partial.push_back(1);
    if (patch < out.spread_of.size()) {
        const Spread spread = out.spread_of[patch];
        out.spread_of.push_back(spread);
    }
    out.fragments.push_back({static_cast<std::uint32_t>(pixel), id, patch,
                             static_cast<float>(depth), kNoPatch, static_cast<float>(depth), one});
}

// Without finer masks, pieces under this many samples' area are partial samples; larger ones
// are point sampled. Much below one: such pieces of a mesh that land on one sample must not
// add up past it (a mesh of faces of half a sample, two to a sample, lost a fifth of its form
// factor at 1; at a quarter a mesh of faces under it keeps 0.975 of it and more)
constexpr double kPartialSamples = 0.25;

// A triangle whose corners all lie within this fraction of the farthest one's distance from
// the shooting point of the shooter's plane lies in that plane (project_patch): a millionth,
// above the planar regions' tolerance (1e-7 of the model's size) over a triangle's reach
constexpr double kInPlane = 1e-6;

template <int S>
void rasterize_abuffer(const Hemicube& hc, int face, const Poly2& p, const DepthPlane& plane,
                       std::uint32_t patch, FragmentBuffer<S>& out, std::size_t& undersampled,
                       const ClosedPixels<S>* closed, bool fine_masks, bool far_depths) {
    const auto dmin = static_cast<float>(plane.fallback);
    const int W = hc.width(face), H = hc.height(face);
    const auto [ymin, ymax] = y_extent(p);
    const int j0 = std::max(0, static_cast<int>(std::floor(ymin)));
    const int j1 = std::min(H, static_cast<int>(std::ceil(ymax)));
    const std::size_t base = hc.face_offset(face);
    double xlo = p[0].x, xhi = p[0].x;
    for (const auto& v : p) {
        xlo = std::min(xlo, v.x);
        xhi = std::max(xhi, v.x);
    }
    const bool in_one_pixel =
        j1 - j0 == 1 && ymin >= j0 && ymax <= j0 + 1.0 && std::floor(xlo) + 1.0 >= xhi;

    RowSpans<S> coarse;
    RowSpans<2 * S> fine;
    // Without finer masks (the elements' rows, the gathers): a piece under a quarter of a
    // sample's area is its area, one partial sample where its centroid lies (partial_sample),
    // whichever samples it happens to hold; a larger one is point sampled, and its pieces that
    // hold no sample of a pixel are left out (below): its samples stand for its area, as they
    // do across the shared edges of a mesh
    if (!fine_masks) {
        const auto [area, c] = area_centroid(p);
        if (area <= 0.5e-14) return;
        const double samples = area * S * S;
        if (samples < kPartialSamples) {
            const int i = std::clamp(static_cast<int>(std::floor(c.x)), 0, W - 1);
            const int j = std::clamp(static_cast<int>(std::floor(c.y)), 0, H - 1);
            const std::size_t pixel = base + static_cast<std::size_t>(j * W + i);
            if (closed && closed->closed_nearer(pixel, dmin)) return;
            ++undersampled;
            partial_sample(patch, pixel, std::clamp(static_cast<int>((c.y - j) * S), 0, S - 1),
                           std::clamp(static_cast<int>((c.x - i) * S), 0, S - 1), samples,
                           plane.depth(hc.proj_a(c.x), hc.proj_b(face, c.y)), out);
            return;
        }
    }
    for (int j = j0; j < j1; ++j) {
        // The columns the polygon touches in the row strip [j, j+1]
        const double y0 = j, y1 = j + 1.0;
        double xmin, xmax;
        if (!strip_x_range(p, y0, y1, xmin, xmax)) continue;
        // The polygon clipped to the strip, made when an undersampled pixel needs it
        Poly2 strip;
        bool strip_ready = false;
        const int i0 = std::max(0, static_cast<int>(std::floor(xmin)));
        const int i1 = std::min(W, static_cast<int>(std::ceil(xmax)));

        // Spans of the S sample rows of this strip; the 2S rows only when a pixel needs them
        coarse.compute(p, y0);
        bool fine_ready = false;
        for (int i = i0; i < i1; ++i) {
            const std::size_t pixel = base + static_cast<std::size_t>(j * W + i);
            // Behind an opaque cover nearer than the whole piece: PropFF gives it nothing
            if (closed && closed->closed_nearer(pixel, dmin)) continue;
            long long count, sum_x, sum_y;
            const Mask<S> mask = coarse.mask(i, count, sum_x, sum_y);
            double sx, sy;
            std::uint32_t fine_index = kNoPatch;
            if (mask.empty()) {
                if (!fine_masks) continue;  // point sampled
                // Clip to the pixel: touching with positive area but no sample = undersampled
                // (a polygon within the pixel is its own clip: the clippers keep it whole)
                Poly2 clipped;
                const Poly2* piece = &p;
                if (!in_one_pixel) {
                    if (!strip_ready) {
                        strip = clip_polygon(p, [&](const glm::dvec2& v) { return v.y - y0; });
                        clip_in_place(strip, [&](const glm::dvec2& v) { return y1 - v.y; });
                        strip_ready = true;
                    }
                    clipped = clip_polygon(strip, [&](const glm::dvec2& v) { return v.x - i; });
                    clip_in_place(clipped, [&](const glm::dvec2& v) { return (i + 1.0) - v.x; });
                    piece = &clipped;
                }
                const Poly2& px = *piece;
                const double area2 = std::abs(signed_area2(px));
                if (px.size() < 3 || area2 <= 1e-14) continue;
                // Centroid of the piece inside the pixel: depth, and the sample of last resort
                glm::dvec2 c(0.0);
                for (const auto& v : px) c += v;
                c /= static_cast<double>(px.size());
                ++undersampled;
                if (!fine_ready) {
                    fine.compute(p, y0);
                    fine_ready = true;
                }
                long long fine_count, fine_x, fine_y;
                Mask<2 * S> fm = fine.mask(i, fine_count, fine_x, fine_y);
                if (fm.empty()) {
                    const int kc = std::clamp(static_cast<int>((c.y - y0) * 2 * S), 0, 2 * S - 1);
                    const int cc = std::clamp(static_cast<int>((c.x - i) * 2 * S), 0, 2 * S - 1);
                    fm.set(kc, cc);
                }
                fine_index = static_cast<std::uint32_t>(out.fine.size());
                out.fine.push_back(fm);
                sx = c.x;
                sy = c.y;
            } else {
                const double scale = 1.0 / (2.0 * S * static_cast<double>(count));
                sx = i + static_cast<double>(sum_x) * scale;
                sy = y0 + static_cast<double>(sum_y) * scale;
            }
            const double depth = plane.depth(hc.proj_a(sx), hc.proj_b(face, sy));
            double far = depth;
            if (far_depths)
                for (int corner = 0; corner < 4; ++corner)
                    far = std::max(far, plane.depth(hc.proj_a(i + (corner & 1)),
                                                    hc.proj_b(face, j + (corner >> 1))));
            out.fragments.push_back({static_cast<std::uint32_t>(pixel), patch, patch,
                                     static_cast<float>(depth), fine_index, static_cast<float>(far),
                                     mask});
        }
    }
}

// Z-buffer: one sample at each pixel centre.
void rasterize_points(const Hemicube& hc, int face, const Poly2& p, const DepthPlane& plane,
                      std::uint32_t patch, FragmentBuffer<1>& out) {
    const int W = hc.width(face), H = hc.height(face);
    const auto [ymin, ymax] = y_extent(p);
    const std::size_t base = hc.face_offset(face);
    int j0, j1;
    sample_range(ymin, ymax, H, j0, j1);
    for (int j = j0; j < j1; ++j) {
        double xl, xr;
        if (!span_at(p, j + 0.5, xl, xr)) continue;
        int i0, i1;
        sample_range(xl, xr, W, i0, i1);
        for (int i = i0; i < i1; ++i) {
            Mask<1> m;
            m.set(0, 0);
            const double depth = plane.depth(hc.proj_a(i + 0.5), hc.proj_b(face, j + 0.5));
            out.fragments.push_back(
                {static_cast<std::uint32_t>(base + static_cast<std::size_t>(j * W + i)), patch,
                 patch, static_cast<float>(depth), kNoPatch, static_cast<float>(depth), m});
        }
    }
}

// Clips a patch (local coordinates) to each face frustum and hands the projected pieces on.
template <typename Emit>
void project_patch(const Hemicube& hc, const glm::dvec3 local[3], Emit&& emit) {
    // Entirely behind the shooter's plane: seen by no face
    if (local[0].z <= 0.0 && local[1].z <= 0.0 && local[2].z <= 0.0) return;
    // In the shooter's own plane: its own surface, or a coplanar neighbour, subtends no solid
    // angle. A hair in front of the point (the planar regions' tolerance, rounding) it would
    // cover the whole hemicube as a ceiling right above the point: a wall element's row then
    // gave its whole power to its own back
    // (squared: no root on every triangle of every hemicube)
    const double z = std::max({std::abs(local[0].z), std::abs(local[1].z), std::abs(local[2].z)});
    const double reach2 = std::max(
        {glm::dot(local[0], local[0]), glm::dot(local[1], local[1]), glm::dot(local[2], local[2])});
    if (z * z <= kInPlane * kInPlane * reach2) return;
    // Points closer than this to the shooting point are dropped (near plane), metres
    constexpr double kNear = 1e-9;
    for (int f = 0; f < kFaceCount; ++f) {
        const glm::dvec3 q[3] = {to_face(f, local[0]), to_face(f, local[1]), to_face(f, local[2])};
        // Clip to the face frustum: d >= near, |sx| <= d, and sy in [-d, d] or [0, d]; a
        // triangle wholly outside one of the planes is rejected before any clipping (as the
        // clipper would: all corners strictly outside)
        const auto near = [](const glm::dvec3& x) { return x.z - kNear; };
        const auto right = [](const glm::dvec3& x) { return x.z - x.x; };
        const auto left = [](const glm::dvec3& x) { return x.z + x.x; };
        const auto top = [](const glm::dvec3& x) { return x.z - x.y; };
        const auto bottom = [f](const glm::dvec3& x) { return f == kTop ? x.z + x.y : x.y; };
        const auto outside = [&q](auto&& plane) {
            return plane(q[0]) < 0.0 && plane(q[1]) < 0.0 && plane(q[2]) < 0.0;
        };
        if (outside(near) || outside(right) || outside(left) || outside(top) || outside(bottom))
            continue;
        Polygon3 poly;
        for (const glm::dvec3& x : q) poly.push_back(x);
        clip_in_place(poly, near);
        clip_in_place(poly, right);
        clip_in_place(poly, left);
        clip_in_place(poly, top);
        clip_in_place(poly, bottom);
        if (poly.size() < 3) continue;
        // Project to pixel coordinates
        Poly2 p2;
        double dmin = poly[0].z;
        for (const auto& c : poly) {
            p2.push_back({std::clamp(hc.pixel_x(c.x / c.z), 0.0, double(hc.width(f))),
                          std::clamp(hc.pixel_y(f, c.y / c.z), 0.0, double(hc.height(f)))});
            dmin = std::min(dmin, c.z);
        }
        if (std::abs(signed_area2(p2)) <= 1e-14) continue;
        // Plane of the patch in face coordinates
        const glm::dvec3 nrm = glm::cross(q[1] - q[0], q[2] - q[0]);
        const DepthPlane plane{nrm, glm::dot(nrm, q[0]), dmin};
        emit(f, p2, plane);
    }
}

// ---------------------------------------------------------------------------------------
// Propagation (Algorithm 1) and occlusion (Algorithm 2) over one pixel's sorted list.

template <typename M>
struct Bundle {
    M mask;
    double transmittance;
    double run;  // the transmittance where the current run of partial pieces began
};

// PropFF, iteratively: the bundles partition the samples still carrying light; each keeps the
// transmittance left after the translucent patches it went through. A partial piece (under a
// quarter of a sample's area, its opacity its coverage of the sample) takes its coverage of the
// light that reached the run of partial pieces it belongs to, as far as any is left: such pieces
// lie side by side within the sample (the small faces of a mesh), so their coverages add up to at
// most the whole sample, where stacking them (1 − Π(1 − α)) would let through a third of the light
// a mesh of tiny faces stops.
//
// Each fragment's share goes out through give(f, in, b, share): list entry f's, for its
// samples `in` that bundle b brings to it.
template <typename M, typename Give>
void propagate(std::span<const M> masks, std::span<const std::uint32_t> patches, Give&& give,
               std::span<const double> opacity, std::span<const char> partial, double delta,
               bool translucency, std::vector<Bundle<M>>& bundles) {
    bundles.clear();
    bundles.push_back({M::full(), 1.0, 1.0});
    const double per_sample = delta / M::kSamples;
    for (std::size_t f = 0; f < masks.size() && !bundles.empty(); ++f) {
        const double alpha = translucency ? opacity[patches[f]] : 1.0;
        const bool part = translucency && partial[patches[f]];
        const std::size_t n = bundles.size();
        for (std::size_t b = 0; b < n; ++b) {
            const M in = bundles[b].mask & masks[f];
            if (in.empty()) continue;
            const double t = bundles[b].transmittance;
            bundles[b].mask = bundles[b].mask.and_not(masks[f]);
            if (part) {
                const double kept = std::min(alpha * bundles[b].run, t);
                give(f, in, b, kept * per_sample * in.count());
                if (kept < t) bundles.push_back({in, t - kept, bundles[b].run});
                continue;
            }
            // Retained by this patch: opacity · ΔF_inside (Eqn 5)
            give(f, in, b, alpha * t * per_sample * in.count());
            if (alpha < 1.0)
                bundles.push_back({in, t * (1.0 - alpha), t * (1.0 - alpha)});  // Eqn 6
        }
        std::erase_if(bundles, [](const Bundle<M>& b) { return b.mask.empty(); });
    }
}

// MergeOcclusionList: the nearer patch of an overlapping pair occludes the farther one; the
// ray bundle is cut by opaque fragments.
template <typename M>
void merge_occlusion(std::span<const M> masks, std::span<const std::uint32_t> patches,
                     std::span<const double> opacity, std::span<const std::uint32_t> patch_of,
                     std::vector<std::uint64_t>& pairs) {
    for (std::size_t a = 0; a < masks.size(); ++a) {
        M test = masks[a];
        for (std::size_t b = a + 1; b < masks.size(); ++b) {
            if ((test & masks[b]).empty()) continue;
            if (patches[b] != patches[a]) {
                const std::uint64_t key =
                    (std::uint64_t{patch_of[patches[b]]} << 32) | patch_of[patches[a]];
                if (pairs.empty() || pairs.back() != key) pairs.push_back(key);
            }
            if (opacity[patches[b]] >= 1.0) {
                test = test.and_not(masks[b]);
                if (test.empty()) break;
            }
        }
    }
}

// The patches to rasterize, front to back (nearest corner first), so occlusion culling finds
// closed pixels.
std::vector<std::pair<double, std::uint32_t>> front_to_back(const ShooterFrame& frame,
                                                            std::span<const Patch> patches,
                                                            const ShootOptions& options) {
    const std::size_t count = options.only ? options.only->size() : patches.size();
    std::vector<std::pair<double, std::uint32_t>> order_fb;
    order_fb.reserve(count);
    for (std::size_t k = 0; k < count; ++k) {
        const std::size_t i = options.only ? (*options.only)[k] : k;
        if (i == options.exclude || i >= patches.size()) continue;
        double near = std::numeric_limits<double>::infinity();
        for (const glm::dvec3& p : patches[i].p)
            near = std::min(near, glm::length(p - frame.origin));
        order_fb.emplace_back(near, static_cast<std::uint32_t>(i));
    }
    std::sort(order_fb.begin(), order_fb.end());
    return order_fb;
}

// Occlusion culling: per pixel, the union of the coverage masks of opaque fragments and the
// deepest of their depths. Once the union is full, a fragment deeper than that depth gets
// nothing (PropFF sorts it behind them), so a piece whose nearest depth lies behind the closed
// depth of every pixel of its bounding rectangle is not rasterized. Form factors are
// unchanged.
template <int S>
class ClosedPixels {
  public:
    explicit ClosedPixels(std::size_t npix)
        : m_covered(npix),
          m_closed_depth(npix, std::numeric_limits<float>::infinity()),
          m_deepest(npix, 0.0f) {}

    // True when the piece `p` of `face`, no nearer than `dmin`, lies behind closed pixels only.
    bool hidden(const Hemicube& hc, int face, const Poly2& p, double dmin) const {
        double x0 = p[0].x, x1 = p[0].x, y0 = p[0].y, y1 = p[0].y;
        for (const auto& v : p) {
            x0 = std::min(x0, v.x);
            x1 = std::max(x1, v.x);
            y0 = std::min(y0, v.y);
            y1 = std::max(y1, v.y);
        }
        return hidden(hc, face, x0, x1, y0, y1, dmin);
    }

    // True when every pixel of the rectangle [x0, x1] × [y0, y1] (pixel coordinates) of `face`
    // is closed nearer than `dmin`.
    bool hidden(const Hemicube& hc, int face, double x0, double x1, double y0, double y1,
                double dmin) const {
        const int W = hc.width(face), H = hc.height(face);
        const int i0 = std::clamp(static_cast<int>(std::floor(x0)), 0, W - 1);
        const int i1 = std::clamp(static_cast<int>(std::ceil(x1)), i0 + 1, W);
        const int j0 = std::clamp(static_cast<int>(std::floor(y0)), 0, H - 1);
        const int j1 = std::clamp(static_cast<int>(std::ceil(y1)), j0 + 1, H);
        const float d = static_cast<float>(dmin);
        const std::size_t base = hc.face_offset(face);
        for (int j = j0; j < j1; ++j)
            for (int i = i0; i < i1; ++i)
                if (!closed_nearer(base + static_cast<std::size_t>(j * W + i), d)) return false;
        return true;
    }

    // True when `pixel` is closed nearer than depth `d`: a fragment there at `d` or deeper gets
    // nothing.
    bool closed_nearer(std::size_t pixel, float d) const { return m_closed_depth[pixel] < d; }

    // Adds the coverage of an opaque patch's fragments [first, end).
    void add(const FragmentBuffer<S>& buffer, std::size_t first) {
        const Mask<S> full = Mask<S>::full();
        for (std::size_t f = first; f < buffer.fragments.size(); ++f) {
            const Fragment<S>& frag = buffer.fragments[f];
            float& cd = m_closed_depth[frag.pixel];
            if (frag.fine != kNoPatch) continue;       // no coarse samples
            if (buffer.partial[frag.patch]) continue;  // covers part of its sample
            // A fragment covering the whole pixel closes it at its own depth
            if (frag.mask == full) {
                cd = std::min(cd, frag.far);
                continue;
            }
            if (!std::isinf(cd)) continue;  // closed
            Mask<S>& m = m_covered[frag.pixel];
            for (int w = 0; w < Mask<S>::kWords; ++w) m.w[w] |= frag.mask.w[w];
            m_deepest[frag.pixel] = std::max(m_deepest[frag.pixel], frag.far);
            // Closed: every sample is behind an opaque fragment no deeper than _deepest_
            if (m == full) cd = m_deepest[frag.pixel];
        }
    }

  private:
    std::vector<Mask<S>> m_covered;
    std::vector<float> m_closed_depth;
    std::vector<float> m_deepest;
};

// True when nothing in `box` can take a form factor: it lies wholly behind the shooter's
// plane, or on every face it reaches behind closed pixels. Conservative: the projection of a
// box wholly in front of a face is inside the bounds of its corners' projections, its depth
// no less than its nearest corner's; a box reaching behind a face's near plane is taken to
// cover the whole face.
template <int S>
bool box_hidden(const ShooterFrame& frame, const Hemicube& hc, const ClosedPixels<S>& closed,
                const Box& box) {
    glm::dvec3 local[8];
    bool ahead = false;
    for (int k = 0; k < 8; ++k) {
        local[k] = frame.to_local({k & 1 ? box.hi.x : box.lo.x, k & 2 ? box.hi.y : box.lo.y,
                                   k & 4 ? box.hi.z : box.lo.z});
        ahead = ahead || local[k].z > 0.0;
    }
    if (!ahead) return true;
    constexpr double kInf = std::numeric_limits<double>::infinity();
    for (int f = 0; f < kFaceCount; ++f) {
        double a0 = kInf, a1 = -kInf, b0 = kInf, b1 = -kInf, dmin = kInf, dmax = -kInf;
        double xlo = kInf, xhi = -kInf, ylo = kInf, yhi = -kInf;
        for (const glm::dvec3& l : local) {
            const glm::dvec3 q = to_face(f, l);
            dmin = std::min(dmin, q.z);
            dmax = std::max(dmax, q.z);
            xlo = std::min(xlo, q.x);
            xhi = std::max(xhi, q.x);
            ylo = std::min(ylo, q.y);
            yhi = std::max(yhi, q.y);
            if (q.z > 0.0) {
                a0 = std::min(a0, q.x / q.z);
                a1 = std::max(a1, q.x / q.z);
                b0 = std::min(b0, q.y / q.z);
                b1 = std::max(b1, q.y / q.z);
            }
        }
        if (dmax <= 0.0) continue;  // wholly behind this face
        const double bottom = f == kTop ? -1.0 : 0.0;
        double near = dmin;
        if (dmin <= 0.0) {
            // Through this face the box shows only its points in the face's frustum, |x| <= z
            // and bottom·z <= y <= z: their depth is at least the least |x| (and y) of the
            // box, and each projects between its x (y) range over that depth and dmax. So a
            // box beside the shooter, reaching behind the face's near plane, is still culled
            // where the face is closed (the rooms along a floor's axes through the shooter)
            const auto least_abs = [](double lo, double hi) {
                return lo > 0.0 ? lo : (hi < 0.0 ? -hi : 0.0);
            };
            near =
                std::max(least_abs(xlo, xhi), f == kTop ? least_abs(ylo, yhi) : std::max(ylo, 0.0));
            if (near > dmax) continue;  // misses the frustum
            if (near > 0.0) {
                a0 = std::min(xlo / near, xlo / dmax);
                a1 = std::max(xhi / near, xhi / dmax);
                b0 = std::min(ylo / near, ylo / dmax);
                b1 = std::max(yhi / near, yhi / dmax);
            }
        }
        double x0 = 0.0, x1 = hc.width(f), y0 = 0.0, y1 = hc.height(f);
        if (near > 0.0) {
            if (a1 < -1.0 || a0 > 1.0 || b1 < bottom || b0 > 1.0) continue;  // off this face
            x0 = hc.pixel_x(std::max(a0, -1.0));
            x1 = hc.pixel_x(std::min(a1, 1.0));
            y0 = hc.pixel_y(f, std::max(b0, bottom));
            y1 = hc.pixel_y(f, std::min(b1, 1.0));
        }
        if (!closed.hidden(hc, f, x0, x1, y0, y1, std::max(near, 0.0))) return false;
    }
    return true;
}

// The large occluders (ShootOptions::occluders_first), each in front of the shooter's plane
// handed to `rasterize`: those within `near` of the shooter nearest corner first, the others
// through their BVH, front to back, their nodes entered as `enter` says.
template <typename Enter, typename Rasterize>
void rasterize_occluders(const ShooterFrame& frame, std::span<const Patch> patches,
                         const Occluders& occluders, std::uint32_t exclude, Enter&& enter,
                         Rasterize&& rasterize) {
    const auto ahead = [&](std::uint32_t id) {
        bool a = false;
        for (const glm::dvec3& x : patches[id].p)
            a = a || glm::dot(x - frame.origin, frame.n) > 0.0;
        return a && id != exclude;
    };
    Box near_box;
    near_box.grow(frame.origin - glm::dvec3(occluders.near));
    near_box.grow(frame.origin + glm::dvec3(occluders.near));
    thread_local std::vector<std::pair<double, std::uint32_t>> nearest_first;
    nearest_first.clear();
    if (occluders.near > 0.0)
        occluders.bvh.query(near_box, [&](std::uint32_t k) {
            const std::uint32_t id = occluders.ids[k];
            if (!ahead(id)) return;
            double nearest = std::numeric_limits<double>::infinity();
            for (const glm::dvec3& x : patches[id].p)
                nearest = std::min(nearest, glm::dot(x - frame.origin, x - frame.origin));
            nearest_first.emplace_back(nearest, id);
        });
    std::sort(nearest_first.begin(), nearest_first.end());
    for (const auto& [d2, id] : nearest_first) rasterize(id);
    occluders.bvh.front_to_back(frame.origin, enter, [&](std::uint32_t k) {
        if (occluders.near > 0.0 && occluders.bvh.box(k).overlaps(near_box)) return;
        if (ahead(occluders.ids[k])) rasterize(occluders.ids[k]);
    });
}

// Scan-converts the patches into fragments, nearest first; culls pieces (and, walking a BVH,
// whole nodes) behind closed pixels when no occlusion lists are asked for (Algorithm 2 lists
// hidden patches behind their occluders too) or when the walk is asked to cull them anyway
// (ShootOptions::cull_listed).
template <int S>
void scan_convert(const ShooterFrame& frame, std::span<const Patch> patches, const Hemicube& hc,
                  const ShootOptions& options, FragmentBuffer<S>& buffer, ShootResult& result) {
    const bool walk = options.bvh && !options.only;
    const bool cull = !options.occlusion || (walk && options.cull_listed);
    ClosedPixels<S> closed(hc.pixel_count());
    const auto rasterize = [&](std::uint32_t id) {
        const auto local_id = static_cast<std::uint32_t>(buffer.patch_of.size());
        buffer.patch_of.push_back(id);
        buffer.opacity.push_back(patches[id].opacity);
        buffer.partial.push_back(0);
        const glm::dvec3 local[3] = {frame.to_local(patches[id].p[0]),
                                     frame.to_local(patches[id].p[1]),
                                     frame.to_local(patches[id].p[2])};
        // With Targets: a patch that is one target gives it its fragments now; the others'
        // are found in propagate, where each fragment's visible samples are known
        // (resolve_pixels), through the patch's plane and grid
        std::uint32_t target = kNoPatch;
        if (options.targets) {
            Spread spread;
            const glm::dvec3 n = glm::cross(local[1] - local[0], local[2] - local[0]);
            spread.plane = glm::dvec4(n, glm::dot(n, local[0]));
            if (const std::uint32_t whole = options.targets->whole(id); whole != kNoPatch)
                target = buffer.local_targets.id(whole, buffer.target_of);
            buffer.spread_of.push_back(spread);
        }
        const bool opaque = patches[id].opacity >= 1.0;
        project_patch(hc, local, [&](int face, const Poly2& p, const DepthPlane& plane) {
            if (cull && closed.hidden(hc, face, p, plane.fallback)) {
                ++result.hidden_pieces;
                return;
            }
            const std::size_t first = buffer.fragments.size();
            if constexpr (S == 1)
                rasterize_points(hc, face, p, plane, local_id, buffer);
            else
                rasterize_abuffer<S>(hc, face, p, plane, local_id, buffer,
                                     result.undersampled_pixels, cull ? &closed : nullptr,
                                     options.fine_masks || !(options.sparse || options.targets),
                                     options.targets != nullptr);
            if (options.targets)
                for (std::size_t f = first; f < buffer.fragments.size(); ++f)
                    buffer.fragments[f].target = target;
            if (opaque) closed.add(buffer, first);
        });
    };
    if (walk) {
        const auto enter = [&](const Box& box) {
            if (!cull || !box_hidden(frame, hc, closed, box)) return true;
            ++result.hidden_nodes;
            return false;
        };
        // Large occluders first: the walls and slabs close pixels before the clutter behind
        // them is walked. Those near the shooter go nearest first (the room's own walls), the
        // others through their BVH, so that a wall of the next room finds the pixels this
        // room's walls closed and is not visited at all
        std::span<const std::uint32_t> first;
        if (const Occluders* occluders = options.occluders_first) {
            first = occluders->ids;
            rasterize_occluders(frame, patches, *occluders, options.exclude, enter, rasterize);
        }
        options.bvh->front_to_back(frame.origin, enter, [&](std::uint32_t id) {
            if (id != options.exclude && id < patches.size() &&
                !std::binary_search(first.begin(), first.end(), id))
                rasterize(id);
        });
    } else {
        for (const auto& nearest_and_patch : front_to_back(frame, patches, options))
            rasterize(nearest_and_patch.second);
    }
    result.visited = buffer.patch_of.size();
    if (options.cull_listed) result.rasterized = buffer.patch_of;
    result.fragments = buffer.fragments.size();
}

// ff[local] += share, ff grown to hold it (with Targets, cells get local ids as they are met)
inline void add_share(std::vector<double>& ff, std::uint32_t local, double share) {
    if (local >= ff.size()) ff.resize(local + 1, 0.0);
    ff[local] += share;
}

// With Targets, a fragment of a patch spanning several targets gives what its samples `in`
// bring it to the cells they see on the patch (a sample's ray met with the patch's plane).
// When the pixel's corners lie in one cell, that cell takes it all (one_cell). Otherwise it
// goes out in kStrata equal parts, one per consecutive run of `in` (row order), each to the
// cell of one sample of the run drawn by a hash of the shooting point, the pixel and the
// bundle: the same on every thread and rank, and over the shooters of a scene each cell gets
// the pixel in proportion to what it shows of it. (The pixel's centre gave a whole pixel to
// one cell alike for every shooter in a plane: bands of ±10 % along a wall's rows of cells
// with R = 32 rows. One sample left noise of ±10 %, two ±5 %, four ±4 % at 7 % more CPU for
// the FZK-Haus's bake where two cost 1 %.)
//
// The list is sorted by each fragment's depth at its samples' centroid, so a sample it gives a
// fragment may lie behind a later fragment's plane: at a wall's foot, the floor's samples
// beyond the wall, in a cell the shooter cannot see (the floor behind a partition). A drawn
// sample that a later opaque fragment covering it hides is drawn again within its run (kDraws
// in all), then left to the fragment's own point at the pixel's centre. The later fragments
// are there to ask: with Targets a pixel closes at its fragments' far depths (Fragment::far),
// so a fragment is culled only behind the whole of the pixel's cover.
template <int S>
class CellShares {
  public:
    static constexpr int kStrata = 2, kDraws = 4;

    CellShares(const ShooterFrame& frame, FragmentBuffer<S>& buffer, const Hemicube& hc,
               const Targets& targets, std::vector<double>& ff)
        : m_frame(frame), m_buffer(buffer), m_hc(hc), m_targets(targets), m_ff(ff) {
        for (int k = 0; k < 3; ++k)
            m_seed = mix_bits(m_seed ^ std::bit_cast<std::uint64_t>(frame.origin[k]));
    }

    // The pixel the next fragments lie in (pixels come in increasing order)
    void at_pixel(std::size_t px) {
        while (m_face + 1 < kFaceCount && px >= m_hc.face_offset(m_face + 1)) ++m_face;
        const auto W = static_cast<std::size_t>(m_hc.width(m_face));
        m_row = (px - m_hc.face_offset(m_face)) / W;
        m_column = (px - m_hc.face_offset(m_face)) % W;
    }

    // Gives `share`, what bundle `bundle` brings entry f of the pixel's sorted `list` through
    // its samples `in`, to the cells they see (`masks`: the list's masks)
    template <typename M>
    void give(std::span<const std::uint32_t> list, std::span<const M> masks, std::size_t f,
              const M& in, std::size_t bundle, double share) {
        const Fragment<S>& frag = m_buffer.fragments[list[f]];
        const std::uint32_t id = m_buffer.patch_of[frag.patch];
        Spread& spread = m_buffer.spread_of[frag.patch];
        if (!spread.grid) spread.find_grid(m_targets, id, m_frame);
        if (const std::optional<glm::ivec2> cell = one_cell(frag))
            return give_cell(id, *cell, share);
        std::uint64_t h = mix_bits(m_seed ^ frag.pixel);
        if (bundle > 0) h = mix_bits(h + bundle);
        const int count = in.count(), strata = std::min(count, kStrata);
        const double part = share / strata;
        for (int stratum = 0; stratum < strata; ++stratum) {
            const int lo = stratum * count / strata, n = (stratum + 1) * count / strata - lo;
            bool seen = false;
            for (int draw = 0; draw < kDraws && !seen; ++draw, h = mix_bits(h)) {
                const auto pick =
                    static_cast<int>(((h >> 32) * static_cast<std::uint64_t>(n)) >> 32);
                const int sample = in.nth(lo + pick);
                const int k = sample / M::kSide, c = sample % M::kSide;
                const glm::dvec3 r = ray((c + 0.5) / M::kSide, (k + 0.5) / M::kSide);
                const double t = meet(frag, r);
                seen = t > 0.0 && !hidden(list, masks, f, k, c, r, t);
                if (seen) give_cell(id, cell_of(spread, r, t), part);
            }
            if (!seen) {
                const glm::dvec3 r = ray(0.5, 0.5);
                const double t = meet(frag, r);
                give_cell(id, cell_of(spread, r, t > 0.0 ? t : double(frag.depth)), part);
            }
        }
    }

  private:
    // The ray through (a, b) of the pixel, in the shooter's frame
    glm::dvec3 ray(double a, double b) const {
        return from_face(m_face, {m_hc.proj_a(double(m_column) + a),
                                  m_hc.proj_b(m_face, double(m_row) + b), 1.0});
    }

    // Where a ray meets a fragment's plane: t, the point being t·r (0 when it does not)
    double meet(const Fragment<S>& frag, const glm::dvec3& r) const {
        const glm::dvec4& plane = m_buffer.spread_of[frag.patch].plane;
        const double along = glm::dot(glm::dvec3(plane), r);
        return along != 0.0 ? plane.w / along : 0.0;
    }

    // The cell of the patch's grid holding the point t·r
    static glm::ivec2 cell_of(const Spread& spread, const glm::dvec3& r, double t) {
        const glm::dvec3 l = t * r;
        return glm::ivec2(
            static_cast<int>(std::floor(glm::dot(glm::dvec3(spread.i), l) + spread.i.w)),
            static_cast<int>(std::floor(glm::dot(glm::dvec3(spread.j), l) + spread.j.w)));
    }

    // The pixel's corners on a fragment's plane all in one cell: that cell, its samples' too
    std::optional<glm::ivec2> one_cell(const Fragment<S>& frag) const {
        glm::ivec2 first(0);
        for (int corner = 0; corner < 4; ++corner) {
            const glm::dvec3 r = ray(corner & 1, corner >> 1);
            const double t = meet(frag, r);
            if (t <= 0.0) return std::nullopt;
            const glm::ivec2 cell = cell_of(m_buffer.spread_of[frag.patch], r, t);
            if (corner == 0)
                first = cell;
            else if (cell != first)
                return std::nullopt;
        }
        return first;
    }

    // True when a later opaque fragment covering sample (k, c) meets its ray r nearer than t
    // (sorted by depth: those deeper than entry f's deepest point over the pixel lie behind
    // it, but for a steep one crossing it there)
    template <typename M>
    bool hidden(std::span<const std::uint32_t> list, std::span<const M> masks, std::size_t f, int k,
                int c, const glm::dvec3& r, double t) const {
        const float far = m_buffer.fragments[list[f]].far;
        for (std::size_t g = f + 1; g < list.size(); ++g) {
            const Fragment<S>& other = m_buffer.fragments[list[g]];
            if (other.depth > far) break;
            if (!masks[g].test(k, c) || m_buffer.opacity[other.patch] < 1.0) continue;
            const double u = meet(other, r);
            if (u > 0.0 && u < t) return true;
        }
        return false;
    }

    // A cell's share, its target's local id remembered (a fragment's samples mostly see one)
    void give_cell(std::uint32_t id, glm::ivec2 cell, double share) {
        if (id != m_last_patch || cell != m_last_cell) {
            m_last_patch = id;
            m_last_cell = cell;
            m_last_local =
                m_buffer.local_targets.id(m_targets.cell(id, cell.x, cell.y), m_buffer.target_of);
        }
        add_share(m_ff, m_last_local, share);
    }

    const ShooterFrame& m_frame;
    FragmentBuffer<S>& m_buffer;
    const Hemicube& m_hc;
    const Targets& m_targets;
    std::vector<double>& m_ff;
    std::uint64_t m_seed = 0;
    int m_face = 0;
    std::size_t m_row = 0, m_column = 0;
    std::uint32_t m_last_patch = kNoPatch, m_last_local = kNoPatch;
    glm::ivec2 m_last_cell{0};
};

// Per pixel, the depth-sorted fragment list: form factors propagated through it (PropFF) into
// `ff` (by local id) and, when asked, its occlusion pairs (MergeOcclusionList), as (receiver
// << 32 | occluder) keys.
template <int S>
void resolve_pixels(const ShooterFrame& frame, FragmentBuffer<S>& buffer, const Hemicube& hc,
                    const ShootOptions& options, std::vector<double>& ff,
                    std::vector<std::uint64_t>& pairs,
                    std::chrono::steady_clock::duration& occlusion_time) {
    const bool abuffer = options.method == Visibility::ABuffer;
    const std::span<const double> opacity = buffer.opacity;
    const std::span<const char> partial = buffer.partial;
    const std::span<const std::uint32_t> patch_of = buffer.patch_of;
    // Bucket fragments by pixel (counting sort), then sort each list by depth
    const std::size_t npix = hc.pixel_count();
    std::vector<std::uint32_t> start(npix + 1, 0);
    for (const auto& f : buffer.fragments) ++start[f.pixel + 1];
    for (std::size_t i = 0; i < npix; ++i) start[i + 1] += start[i];
    std::vector<std::uint32_t> order(buffer.fragments.size());
    {
        std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
        for (std::size_t i = 0; i < buffer.fragments.size(); ++i)
            order[fill[buffer.fragments[i].pixel]++] = static_cast<std::uint32_t>(i);
    }

    std::vector<Mask<S>> masks;
    std::vector<Mask<2 * S>> fine_masks;
    std::vector<std::uint32_t> ids;
    std::vector<Bundle<Mask<S>>> bundles;
    std::vector<Bundle<Mask<2 * S>>> fine_bundles;
    std::optional<CellShares<S>> cells;
    if (options.targets) cells.emplace(frame, buffer, hc, *options.targets, ff);
    for (std::size_t px = 0; px < npix; ++px) {
        auto first = order.begin() + start[px], last = order.begin() + start[px + 1];
        if (first == last) continue;
        if (cells) cells->at_pixel(px);
        // Ties in depth go by patch index, whatever the order the patches were visited in
        std::sort(first, last, [&](std::uint32_t a, std::uint32_t b) {
            const auto &fa = buffer.fragments[a], &fb = buffer.fragments[b];
            return fa.depth < fb.depth ||
                   (fa.depth == fb.depth && patch_of[fa.patch] < patch_of[fb.patch]);
        });
        masks.clear();
        ids.clear();
        bool fine = false;
        for (auto it = first; it != last; ++it) {
            const auto& f = buffer.fragments[*it];
            masks.push_back(f.mask);
            ids.push_back(f.patch);
            fine = fine || f.fine != kNoPatch;
        }
        const std::span<const std::uint32_t> list(&*first, &*first + (last - first));
        // Each fragment's share to its target, or with Targets to the cells it shows
        const auto target = [&]<typename M>(std::size_t f, const M& in, std::size_t bundle,
                                            double share) {
            const std::uint32_t t = buffer.fragments[list[f]].target;
            if (t != kNoPatch)
                add_share(ff, t, share);
            else if constexpr (std::is_same_v<M, Mask<S>>)
                cells->give(list, std::span<const M>(masks), f, in, bundle, share);
            else
                cells->give(list, std::span<const M>(fine_masks), f, in, bundle, share);
        };
        const double delta = hc.delta(px);
        if (!fine) {
            propagate<Mask<S>>(masks, ids, target, opacity, partial, delta, abuffer, bundles);
            if (options.occlusion && masks.size() > 1) {
                const auto t0 = std::chrono::steady_clock::now();
                merge_occlusion<Mask<S>>(masks, ids, opacity, patch_of, pairs);
                occlusion_time += std::chrono::steady_clock::now() - t0;
            }
        } else {
            // Undersampled pixel: the whole list at the finer mask resolution
            fine_masks.clear();
            for (auto it = first; it != last; ++it) {
                const auto& f = buffer.fragments[*it];
                fine_masks.push_back(f.fine != kNoPatch ? buffer.fine[f.fine] : upsample(f.mask));
            }
            propagate<Mask<2 * S>>(fine_masks, ids, target, opacity, partial, delta, abuffer,
                                   fine_bundles);
            if (options.occlusion && fine_masks.size() > 1) {
                const auto t0 = std::chrono::steady_clock::now();
                merge_occlusion<Mask<2 * S>>(fine_masks, ids, opacity, patch_of, pairs);
                occlusion_time += std::chrono::steady_clock::now() - t0;
            }
        }
    }
}

template <int S>
ShootResult shoot_with(const ShooterFrame& frame, std::span<const Patch> patches,
                       const Hemicube& hc, const ShootOptions& options) {
    ShootResult result;
    // Each thread keeps its buffer's storage from shot to shot
    thread_local FragmentBuffer<S> buffer;
    buffer.clear();
    scan_convert<S>(frame, patches, hc, options, buffer, result);
    // Form factors by local target id: the patch's own, or a Targets' (each visited once)
    const std::vector<std::uint32_t>& target_of =
        options.targets ? buffer.target_of : buffer.patch_of;
    std::vector<double> ff(target_of.size(), 0.0);
    std::vector<std::uint64_t> pairs;
    std::chrono::steady_clock::duration occlusion_time{};
    resolve_pixels<S>(frame, buffer, hc, options, ff, pairs, occlusion_time);
    // The patches absorb or stop at most what leaves the shooting point (ΔF sum to 1)
    ABRAD_DCHECK(std::accumulate(ff.begin(), ff.end(), 0.0) <= 1.0 + 1e-9,
                 "form factors from one point sum to more than 1");
    // Local ids back to patch (or target) indices
    if (options.sparse || options.targets) {
        for (std::size_t l = 0; l < ff.size(); ++l)
            if (ff[l] > 0.0) result.hits.push_back({target_of[l], ff[l]});
        std::sort(
            result.hits.begin(), result.hits.end(),
            [](const PatchFormFactor& a, const PatchFormFactor& b) { return a.patch < b.patch; });
    } else {
        result.form_factor.assign(patches.size(), 0.0);
        for (std::size_t l = 0; l < ff.size(); ++l) result.form_factor[buffer.patch_of[l]] = ff[l];
    }

    // Deduplicate occlusion pairs
    const auto t_dedup = std::chrono::steady_clock::now();
    result.raw_pairs = pairs.size();
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    result.occlusion.reserve(pairs.size());
    for (std::uint64_t key : pairs)
        result.occlusion.push_back(
            {static_cast<std::uint32_t>(key >> 32), static_cast<std::uint32_t>(key & 0xffffffffu)});
    occlusion_time += std::chrono::steady_clock::now() - t_dedup;
    result.seconds_occlusion = std::chrono::duration<double>(occlusion_time).count();
    return result;
}

}  // namespace

std::span<const OcclusionPair> ShootResult::occluders_of(std::uint32_t receiver) const {
    auto lo =
        std::lower_bound(occlusion.begin(), occlusion.end(), receiver,
                         [](const OcclusionPair& p, std::uint32_t r) { return p.receiver < r; });
    auto hi =
        std::upper_bound(lo, occlusion.end(), receiver,
                         [](std::uint32_t r, const OcclusionPair& p) { return r < p.receiver; });
    return {lo, hi};
}

ShootResult shoot(const ShooterFrame& frame, std::span<const Patch> patches,
                  const Hemicube& hemicube, const ShootOptions& options) {
    if (options.method == Visibility::ZBuffer)
        return shoot_with<1>(frame, patches, hemicube, options);
    switch (options.subpixels) {
        case 4:
            return shoot_with<4>(frame, patches, hemicube, options);
        case 8:
            return shoot_with<8>(frame, patches, hemicube, options);
        case 16:
            return shoot_with<16>(frame, patches, hemicube, options);
        default:
            throw std::invalid_argument("A-buffer subpixels must be 4, 8 or 16, got " +
                                        std::to_string(options.subpixels));
    }
}

Occluders large_occluders(std::span<const Patch> patches, double min_area, double near) {
    std::vector<std::uint32_t> ids;
    std::vector<Box> boxes;
    for (std::size_t t = 0; t < patches.size(); ++t)
        if (patches[t].opacity >= 1.0 && area(patches[t]) >= min_area) {
            ids.push_back(static_cast<std::uint32_t>(t));
            Box& b = boxes.emplace_back();
            for (const glm::dvec3& x : patches[t].p) b.grow(x);
        }
    return {std::move(ids), Bvh(std::move(boxes)), near};
}

std::string to_string(Visibility method) {
    return method == Visibility::ZBuffer ? "zbuffer" : "abuffer";
}

}  // namespace abrad::radiosity
