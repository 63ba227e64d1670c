// Google Benchmark microbenchmarks of the bake's stages on fixed synthetic inputs:
// hemicube shooting (scan conversion + PropFF), the same with occlusion lists (the difference
// is MergeOcclusionList), exact visible form factors, shadow edges and the CDT mesher.
// Run: build/release/tools/abrad_microbench [--benchmark_filter=Shoot]

#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "abrad/radiosity/dm_mesh.h"
#include "abrad/radiosity/exact.h"
#include "abrad/radiosity/hemicube.h"
#include "abrad/radiosity/shadow_edges.h"
#include "abrad/radiosity/shoot.h"

namespace {

using namespace abrad::radiosity;

// A room 6 x 6 x 3 m of n x n cells per face and k x k floating occluder squares above the floor.
std::vector<Patch> room(int n, int k) {
    std::vector<Patch> out;
    auto rect = [&](glm::dvec3 o, glm::dvec3 u, glm::dvec3 v, int cells, double opacity) {
        for (int j = 0; j < cells; ++j)
            for (int i = 0; i < cells; ++i) {
                const glm::dvec3 a = o + u * (double(i) / cells) + v * (double(j) / cells);
                const glm::dvec3 b = a + u / double(cells), d = a + v / double(cells),
                                 c = b + v / double(cells);
                out.push_back({{a, b, c}, opacity});
                out.push_back({{a, c, d}, opacity});
            }
    };
    rect({-3, -3, 0}, {6, 0, 0}, {0, 6, 0}, n, 1.0);
    rect({-3, -3, 0}, {0, 0, 3}, {6, 0, 0}, n, 1.0);
    rect({3, 3, 0}, {0, 0, 3}, {-6, 0, 0}, n, 1.0);
    rect({3, -3, 0}, {0, 0, 3}, {0, 6, 0}, n, 1.0);
    rect({-3, 3, 0}, {0, 0, 3}, {0, -6, 0}, n, 1.0);
    for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
            const glm::dvec3 o{-2.5 + 5.0 * i / k, -2.5 + 5.0 * j / k, 1.0 + 0.1 * ((i + j) % 3)};
            rect(o, {0.3, 0, 0}, {0, 0.3, 0}, 1, (i + j) % 4 == 0 ? 0.5 : 1.0);
        }
    return out;
}

const ShooterFrame kFrame = ShooterFrame::at({0.1, 0.05, 2.95}, {0, 0, -1});

void shoot_bench(benchmark::State& state, Visibility method, int subpixels, bool occlusion) {
    const std::vector<Patch> patches = room(20, 8);
    const Hemicube hc(static_cast<int>(state.range(0)));
    std::size_t fragments = 0;
    for (auto _ : state) {
        const ShootResult r =
            shoot(kFrame, patches, hc,
                  {.method = method, .subpixels = subpixels, .occlusion = occlusion});
        fragments = r.fragments;
        benchmark::DoNotOptimize(r.form_factor.data());
    }
    state.counters["patches"] = double(patches.size());
    state.counters["fragments"] = double(fragments);
}

void BM_ShootZBuffer(benchmark::State& s) { shoot_bench(s, Visibility::ZBuffer, 8, false); }
void BM_ShootABuffer4(benchmark::State& s) { shoot_bench(s, Visibility::ABuffer, 4, false); }
void BM_ShootABuffer8(benchmark::State& s) { shoot_bench(s, Visibility::ABuffer, 8, false); }
void BM_ShootABuffer16(benchmark::State& s) { shoot_bench(s, Visibility::ABuffer, 16, false); }
void BM_ShootABuffer8Occlusion(benchmark::State& s) {
    shoot_bench(s, Visibility::ABuffer, 8, true);
}
BENCHMARK(BM_ShootZBuffer)->Arg(50)->Arg(100)->Arg(200)->Arg(400)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ShootABuffer4)->Arg(26)->Arg(50)->Arg(100)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ShootABuffer8)->Arg(26)->Arg(50)->Arg(100)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ShootABuffer16)->Arg(26)->Arg(50)->Arg(100)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ShootABuffer8Occlusion)->Arg(26)->Arg(50)->Arg(100)->Unit(benchmark::kMillisecond);

void BM_VisibleFormFactor(benchmark::State& state) {
    const std::vector<Patch> occluders = room(1, static_cast<int>(state.range(0)));
    std::vector<const Patch*> occ;
    for (std::size_t i = 10; i < occluders.size(); ++i) occ.push_back(&occluders[i]);
    const Patch light{{{-0.3, -0.3, 2.95}, {-0.3, 0.3, 2.95}, {0.3, 0.3, 2.95}}, 1.0};
    double sum = 0.0;
    int i = 0;
    for (auto _ : state) {
        const glm::dvec3 x{-2.0 + 0.01 * (i % 400), -1.0 + 0.005 * (i % 400), 0.0};
        sum += visible_form_factor(x, {0, 0, 1}, light, occ);
        ++i;
    }
    benchmark::DoNotOptimize(sum);
    state.counters["occluders"] = double(occ.size());
}
BENCHMARK(BM_VisibleFormFactor)->Arg(4)->Arg(8)->Arg(16);

void BM_ShadowEdges(benchmark::State& state) {
    const std::vector<Patch> occluders = room(1, static_cast<int>(state.range(0)));
    std::vector<const Patch*> occ;
    for (std::size_t i = 10; i < occluders.size(); ++i) occ.push_back(&occluders[i]);
    const Patch light{{{-0.3, -0.3, 2.95}, {-0.3, 0.3, 2.95}, {0.3, 0.3, 2.95}}, 1.0};
    const Patch receiver{{{-3, -3, 0}, {3, -3, 0}, {3, 3, 0}}, 1.0};
    std::size_t n = 0;
    for (auto _ : state) n += shadow_edges(light, LightModel::Area, receiver, occ).size();
    benchmark::DoNotOptimize(n);
}
BENCHMARK(BM_ShadowEdges)->Arg(4)->Arg(8);

// CDT of a 6 x 6 m square with `range` crossing shadow-edge constraints
void BM_ConstrainedDelaunay(benchmark::State& state) {
    PlanarRegion r;
    r.normal = {0, 0, 1};
    r.positions = {{0, 0, 0}, {6, 0, 0}, {6, 6, 0}, {0, 6, 0}};
    r.triangles = {{0, 1, 2}, {0, 2, 3}};
    const int n = static_cast<int>(state.range(0));
    for (int i = 0; i < n; ++i) {
        const double a = 0.3 + 5.4 * i / n, b = 5.7 - 4.0 * i / n;
        r.constraints.push_back({glm::dvec3{a, 0.2, 0}, glm::dvec3{b, 5.8, 0}});
        r.constraints.push_back({glm::dvec3{0.2, a, 0}, glm::dvec3{5.8, b + 0.01 * i, 0}});
    }
    const std::vector<PlanarRegion> regions{r};
    std::size_t tris = 0;
    for (auto _ : state) tris = mesh_regions(regions, {})[0].triangles.size();
    state.counters["triangles"] = double(tris);
}
BENCHMARK(BM_ConstrainedDelaunay)->Arg(10)->Arg(40)->Arg(160)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
