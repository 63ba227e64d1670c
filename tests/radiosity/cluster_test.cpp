// The pieces of the distributed bake that need no MPI (cluster.h, exact_sum.h): sums whose
// bits do not depend on the order of their terms or on how they are split over ranks, and the
// split of work items by cost.

#include "abrad/radiosity/cluster.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "abrad/radiosity/exact_sum.h"

namespace abrad::radiosity {
namespace {

// Terms of an irradiance sum: many sizes, from 1e-12 to 1e6 W/m², a few negative.
std::vector<double> terms(std::size_t n, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> exponent(-12.0, 6.0), sign(0.0, 1.0);
    std::vector<double> t(n);
    for (double& x : t) x = std::pow(10.0, exponent(rng)) * (sign(rng) < 0.1 ? -1.0 : 1.0);
    return t;
}

double exact_sum_of(const std::vector<double>& t) {
    ExactSums s(1);
    for (const double x : t) s.add(0, x);
    return s.value(0);
}

TEST(ExactSums, TheSameBitsInAnyOrder) {
    std::vector<double> t = terms(5000, 1);
    const double first = exact_sum_of(t);
    std::mt19937_64 rng(2);
    for (int round = 0; round < 20; ++round) {
        std::shuffle(t.begin(), t.end(), rng);
        EXPECT_EQ(exact_sum_of(t), first);
    }
    // The plain double sum does depend on the order (the test can tell the difference)
    std::vector<double> sorted = t;
    std::sort(sorted.begin(), sorted.end());
    const double up = std::accumulate(sorted.begin(), sorted.end(), 0.0);
    const double down = std::accumulate(sorted.rbegin(), sorted.rend(), 0.0);
    EXPECT_NE(up, down);
}

TEST(ExactSums, TheSameBitsWhateverTheSplitOverRanks) {
    const std::vector<double> t = terms(3000, 3);
    const double alone = exact_sum_of(t);
    for (const std::size_t ranks : {2u, 3u, 4u, 7u}) {
        // Each "rank" sums its items; the limbs are then added as Cluster::sum adds them
        std::vector<ExactSums> part(ranks, ExactSums(1));
        for (std::size_t i = 0; i < t.size(); ++i) part[(i * 7919) % ranks].add(0, t[i]);
        std::vector<std::int64_t> total(part[0].limbs().size(), 0);
        for (ExactSums& p : part) {
            const std::span<std::int64_t> l = p.limbs();
            for (std::size_t k = 0; k < l.size(); ++k) total[k] += l[k];
        }
        ExactSums combined(1);
        std::copy(total.begin(), total.end(), combined.limbs().begin());
        EXPECT_EQ(combined.value(0), alone) << ranks << " ranks";
    }
}

TEST(ExactSums, AgreesWithALongDoubleSumToRounding) {
    const std::vector<double> t = terms(2000, 4);
    long double reference = 0.0L;
    for (const double x : t) reference += x;
    const double s = exact_sum_of(t);
    EXPECT_NEAR(s, static_cast<double>(reference), 1e-15 * std::abs(s) + 1e-17);
}

TEST(ExactSums, KeepsSmallTermsAndCancellation) {
    ExactSums s(3);
    // 1e6 + 1e-9 - 1e6: a double sum in that order gives 0 past a few bits
    s.add(0, 1e6);
    s.add(0, 1e-9);
    s.add(0, -1e6);
    EXPECT_NEAR(s.value(0), 1e-9, 1e-18);
    // 2^-60 is the last unit kept; exact multiples of it stay exact
    for (int i = 0; i < 1000; ++i) s.add(1, std::ldexp(3.0, -60));
    EXPECT_EQ(s.value(1), std::ldexp(3000.0, -60));
    EXPECT_EQ(s.value(2), 0.0);
}

TEST(ExactSums, CarriesPastManyLargeTerms) {
    ExactSums s(1);
    const double big = std::ldexp(1.0, 40) - 1.0;  // fills a limb's 40 bits
    for (int i = 0; i < 5000000; ++i) s.add(0, big);
    EXPECT_EQ(s.value(0), 5000000.0 * big);
}

TEST(ExactSums, ATermOutOfRangeMakesItsSumNaN) {
    ExactSums s(3);
    s.add(0, 1.0);
    s.add(0, INFINITY);
    s.add(1, std::nan(""));
    s.add(2, 1e18);  // beyond 2^59
    for (std::size_t i = 0; i < 3; ++i) EXPECT_TRUE(std::isnan(s.value(i))) << i;
}

TEST(OwnersByCost, LongestFirstToTheLeastLoadedRank) {
    // 5 -> r0, 4 -> r1, 3 -> r1 (4 < 5), 3 -> r0 (5 < 7), 3 -> r1 (7 < 8)
    const std::vector<double> cost = {3.0, 5.0, 3.0, 4.0, 3.0};
    EXPECT_EQ(owners_by_cost(cost, 2), (std::vector<int>{1, 0, 0, 1, 1}));
    // One rank takes everything; more ranks than items leave some idle
    EXPECT_EQ(owners_by_cost(cost, 1), (std::vector<int>(5, 0)));
    EXPECT_EQ(owners_by_cost(std::vector<double>{1.0, 2.0}, 4), (std::vector<int>{1, 0}));
}

TEST(OwnersByCost, BalancesByCostNotByCount) {
    // One heavy item and many light ones: the heavy one's rank gets nothing else
    std::vector<double> cost(101, 1.0);
    cost[50] = 100.0;
    const std::vector<int> owner = owners_by_cost(cost, 2);
    std::vector<double> load(2, 0.0);
    for (std::size_t i = 0; i < cost.size(); ++i) load[owner[i]] += cost[i];
    EXPECT_EQ(load[0], 100.0);
    EXPECT_EQ(load[1], 100.0);
}

TEST(Cluster, AloneTakesEveryItemAndExchangesNothing) {
    Cluster alone;
    EXPECT_EQ(alone.size(), 1);
    EXPECT_EQ(alone.share(std::vector<double>{3.0, 1.0, 2.0}),
              (std::vector<std::uint32_t>{0, 1, 2}));
    std::vector<std::int64_t> v = {1, 2, 3};
    alone.sum(v, "test");
    EXPECT_EQ(v, (std::vector<std::int64_t>{1, 2, 3}));
    const std::vector<int> mine = {4, 5};
    std::vector<std::size_t> offsets;
    const std::vector<int> all =
        values_of<int>(alone.all_gather(as_bytes_of(mine), "test", &offsets));
    EXPECT_EQ(all, mine);
    EXPECT_EQ(offsets, (std::vector<std::size_t>{0, 2 * sizeof(int)}));
}

}  // namespace
}  // namespace abrad::radiosity
