#pragma once
// Sums of doubles that do not depend on the order of their terms: each term is split into
// three 64-bit integer limbs of a fixed-point number (units 2^20, 2^-20 and 2^-60), so adding
// is integer addition, which is associative. The lights' irradiance is summed this way, so a
// bake gives the same bits whatever order its threads finish in and however many MPI ranks
// share its lights (Cluster::sum adds the limbs of the ranks).
//
// Numeric assumptions: a term of magnitude below 2^59 (5.8e17) is kept exactly down to 2^-60
// (8.7e-19; below that it is rounded to the nearest multiple); a sum is rounded to double at
// most twice when read. A term that is not finite or not below 2^59 makes its sum NaN.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace abrad::radiosity {

/// `size()` order-independent sums of doubles, all 0 at first.
class ExactSums {
  public:
    explicit ExactSums(std::size_t n) : m_limbs(n * kLimbs, 0) {}

    std::size_t size() const { return m_limbs.size() / kLimbs; }

    /// Adds `x` to sum `i`.
    void add(std::size_t i, double x) {
        std::int64_t* l = &m_limbs[i * kLimbs];
        if (!(std::abs(x) < 0x1p59)) {  // also NaN
            ++l[3];
            return;
        }
        // Split x = hi·2^20 + mid·2^-20 + lo·2^-60 (the first two exactly, by truncation)
        const double hi = std::trunc(std::ldexp(x, -20));
        double rest = x - std::ldexp(hi, 20);
        const double mid = std::trunc(std::ldexp(rest, 20));
        rest -= std::ldexp(mid, -20);
        const double lo = std::nearbyint(std::ldexp(rest, 60));
        l[0] += static_cast<std::int64_t>(lo);
        l[1] += static_cast<std::int64_t>(mid);
        l[2] += static_cast<std::int64_t>(hi);
        // Each term adds less than 2^41 to a limb: carry long before 2^63
        if (std::abs(l[0]) > kCarryAt || std::abs(l[1]) > kCarryAt) normalise(l);
    }

    /// Sum `i` as a double (a function of the exact sum only).
    double value(std::size_t i) const {
        std::int64_t l[kLimbs];
        for (std::size_t k = 0; k < kLimbs; ++k) l[k] = m_limbs[i * kLimbs + k];
        if (l[3] != 0) return std::nan("");
        normalise(l);
        return std::ldexp(static_cast<double>(l[2]), 20) +
               (std::ldexp(static_cast<double>(l[1]), -20) +
                std::ldexp(static_cast<double>(l[0]), -60));
    }

    /// The limbs, normalised (each low limb in [0, 2^40)), for a cluster's integer sum.
    std::span<std::int64_t> limbs() {
        for (std::size_t i = 0; i < size(); ++i) normalise(&m_limbs[i * kLimbs]);
        return m_limbs;
    }

  private:
    static constexpr std::size_t kLimbs = 4;  // lo, mid, hi, count of terms out of range
    static constexpr std::int64_t kCarryAt = std::int64_t{1} << 61;

    // Carries so that lo and mid are in [0, 2^40) (floor division: the form is unique).
    static void normalise(std::int64_t* l) {
        constexpr std::int64_t kBase = std::int64_t{1} << 40;
        for (int k = 0; k < 2; ++k) {
            std::int64_t carry = l[k] / kBase;
            if (l[k] % kBase < 0) --carry;
            l[k] -= carry * kBase;
            l[k + 1] += carry;
        }
    }

    std::vector<std::int64_t> m_limbs;
};

}  // namespace abrad::radiosity
