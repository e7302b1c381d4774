// filmgrain_bench: Google Benchmark kernels of the per-grain pipeline, one
// per MODEL.md stage, each reporting its cost per natural item (per photon,
// per lookup, per grain, per disc) so that whole-frame costs can be
// predicted and regressions located:
//
//   BM_Chain/N             latent-image chain (MODEL.md 3), N photons per
//                          grain; items = photons
//   BM_ChainEarlyStop/N    the same, stopped once n4 reaches 1 (what
//                          kinetics=early does for a typical develop
//                          uniform); items = photons
//   BM_TableBuild/N        DevelopTable construction up to N photons at the
//                          fast engine's node error 5e-3; items = nodes
//   BM_TableLookup/N       DevelopTable::probability for n uniform in
//                          [0, N]; items = lookups
//   BM_Poisson/M           sample_poisson at mean M/10; items = samples
//   BM_GrainGeneration/D   PopulationGrains::for_each_grain_near over a
//                          400 um square, mean diameter D/10 um; items = grains
//   BM_ExposureDisc/R      LayerExposure::integrate_over_disc, disc diameter
//                          = R/4 input pixels; items = grains
//   BM_ExposureCentre      value_at (photons=centre), for comparison
//   BM_ExposurePlaneDisc/R the fast kernel's ExposurePlane::integrals_over_discs
//                          64 at a time (R = 1, 2, 4 as above), R = 0: its
//                          centre lookup; items = discs
//   BM_GridCoverage/C      grid_coverage (exact) of a 64x64 block of 6.25 um
//                          pixels, discs of the paper stock (6 um, sigma
//                          0.5) at covered fraction C/100; items = discs
//   BM_ScanlineCoverage/C/S  scanline_coverage, S sub-scanlines; items = discs
//   BM_RasterCoverage/C/S  raster_coverage, 64 x S points per pixel; items =
//                          discs
//   BM_FastKernel/D        the fast per-grain kernel's grain loop: FastGrains
//                          generation over a 400 um square (mean diameter
//                          D/10 um, sigma 0.35) and one DevelopCurve decision
//                          per grain at ~20 mean photons; items = grains
//   BM_PixelModelDraw      sample_pixel_transmittance of a 64x64 block;
//                          items = pixels
//   BM_SpreadFrame/S       spread_frame (MODEL.md 9) of a Super 35 frame
//                          of S pixels wide (4:3), VISION3's red layer:
//                          scatter 0.3 (sigma 5 um) and halation 0.02 from
//                          a 125 um remjet base, edge=clamp; items = pixels
//
// Inputs are generated once per benchmark from fixed seeds. Build with
// -DFILMGRAIN_BUILD_BENCHMARKS=ON (Release); run build/bench/filmgrain_bench
// (Google Benchmark 1.7.1 always prints "built as DEBUG": that is the
// library's own build, not ours).
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <vector>

#include "expect/develop_curve.h"
#include "model/development.h"
#include "model/exposure.h"
#include "model/geometry.h"
#include "kernels/grain_kernel.h"
#include "model/image_formation.h"
#include "kernels/coverage_grid.h"
#include "kernels/coverage_raster.h"
#include "kernels/coverage_scanline.h"
#include "model/kinetics.h"
#include "model/light_spread.h"
#include "engine/kinetics_table.h"
#include "kernels/pixel_model.h"
#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {
namespace {

/// The exposures here never saturate (a value above any the fixtures hold).
constexpr double kNoSaturation = 1e30;

/// The rates of MODEL.md 7 (every preset uses them).
constexpr KineticsRates kRates { 1e7, 1e6, 10.0 };
constexpr double kShutterS = 1.0 / 48.0;

Stock paper_like_stock()
{
    Stock s;
    s.development_time_s = 360.0;
    s.development_tau_s  = 120.0;
    s.fog_tau_s          = 6000.0;
    return s;
}

void BM_Chain(benchmark::State& state)
{
    const uint64_t n = static_cast<uint64_t>(state.range(0));
    uint64_t i = 0, events = 0, n4 = 0;
    for (auto _ : state) {
        Rng rng(hash_ids(7, i++), Stage::kinetics);
        uint64_t ev = 0;
        const LatentImage li = simulate_latent_image(n, kShutterS, kRates, rng, &ev);
        events += ev;
        n4 += li.n4;
        benchmark::DoNotOptimize(li);
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
    state.counters["events/grain"] = static_cast<double>(events) / state.iterations();
    state.counters["n4/grain"]     = static_cast<double>(n4) / state.iterations();
}
BENCHMARK(BM_Chain)->Arg(20)->Arg(200);

void BM_ChainEarlyStop(benchmark::State& state)
{
    const uint64_t n = static_cast<uint64_t>(state.range(0));
    uint64_t i = 0, events = 0;
    for (auto _ : state) {
        Rng rng(hash_ids(7, i++), Stage::kinetics);
        uint64_t ev = 0;
        const LatentImage li = simulate_latent_image(n, kShutterS, kRates, rng, &ev, 1);
        events += ev;
        benchmark::DoNotOptimize(li);
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
    state.counters["events/grain"] = static_cast<double>(events) / state.iterations();
}
BENCHMARK(BM_ChainEarlyStop)->Arg(20)->Arg(200);

std::unique_ptr<DevelopTable> make_table(uint64_t max_photons, double target_se)
{
    const Development dev(paper_like_stock());
    DevelopTable::Options o;
    o.max_photons           = max_photons;
    o.target_standard_error = target_se;
    o.stream_key            = 1;
    o.nthreads              = 1;
    return std::make_unique<DevelopTable>(kRates, kShutterS, dev, o);
}

void BM_TableBuild(benchmark::State& state)
{
    size_t nodes = 0;
    for (auto _ : state) {
        auto t = make_table(static_cast<uint64_t>(state.range(0)), 5e-3);
        nodes  = t->node_count();
        benchmark::DoNotOptimize(t);
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * nodes));
    state.counters["nodes"] = static_cast<double>(nodes);
}
BENCHMARK(BM_TableBuild)->Arg(64)->Arg(1024)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_TableLookup(benchmark::State& state)
{
    const uint64_t nmax = static_cast<uint64_t>(state.range(0));
    static std::unique_ptr<DevelopTable> table = make_table(4096, 2e-2);
    std::vector<uint64_t> ns(4096);
    Rng rng(hash_ids(11, nmax), Stage::photons);
    for (auto& n : ns)
        n = static_cast<uint64_t>(rng.uniform() * static_cast<double>(nmax + 1));
    size_t i  = 0;
    double sum = 0.0;
    for (auto _ : state) {
        sum += table->probability(ns[i++ & 4095]);
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
}
// 64: dense nodes (direct index); 4096: mostly interpolated (binary search).
BENCHMARK(BM_TableLookup)->Arg(64)->Arg(4096);

void BM_Poisson(benchmark::State& state)
{
    const double mean = static_cast<double>(state.range(0)) / 10.0;
    uint64_t i = 0, sum = 0;
    for (auto _ : state) {
        Rng rng(hash_ids(13, i++), Stage::photons);
        sum += sample_poisson(mean, rng);
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
}
// Means 0.5, 5 (inversion) and 50, 500, 5000 (PTRS).
BENCHMARK(BM_Poisson)->Arg(5)->Arg(50)->Arg(500)->Arg(5000)->Arg(50000);

void BM_GrainGeneration(benchmark::State& state)
{
    Population pop;
    pop.diameter_um        = static_cast<double>(state.range(0)) / 10.0;
    pop.diameter_log_sigma = 0.5;
    // Same covered area per um^2 whatever the size (n a = 0.3).
    pop.grains_per_um2     = 0.3 / (M_PI / 4.0 * pop.diameter_um * pop.diameter_um
                                    * std::exp(0.25));
    const PopulationGrains grains(pop, 1, 0, 0);
    uint64_t count = 0, tile = 0;
    for (auto _ : state) {
        // A different 400 um square each time (no cache reuse across tiles).
        const double x0 = 400.0 * static_cast<double>(tile++);
        const RectUm rect { x0, 0.0, x0 + 400.0, 400.0 };
        grains.for_each_grain_near(rect, [&](const Grain& g) {
            ++count;
            benchmark::DoNotOptimize(g.radius_um);
        });
    }
    state.SetItemsProcessed(static_cast<int64_t>(count));
    state.counters["grains/tile"] = static_cast<double>(count) / state.iterations();
}
BENCHMARK(BM_GrainGeneration)->Arg(10)->Arg(35)->Arg(60);

/// A 256 x 256 grey input with varying values, its pitch 1 um.
struct ExposureFixture {
    std::vector<float> pixels;
    ImageView view;
    ExposureFixture() : pixels(256 * 256)
    {
        Rng rng(17, Stage::cell);
        for (auto& p : pixels)
            p = static_cast<float>(0.05 + rng.uniform());
        view.pixels   = pixels.data();
        view.width    = 256;
        view.height   = 256;
        view.channels = 1;
    }
};

/// 4096 fixed points in [20, 220)^2 (the exposure fixture's interior).
std::vector<std::pair<double, double>> random_centres()
{
    std::vector<std::pair<double, double>> centres(4096);
    Rng rng(19, Stage::cell);
    for (auto& c : centres)
        c = { 20.0 + rng.uniform() * 200.0, 20.0 + rng.uniform() * 200.0 };
    return centres;
}

/// The loop of the exposure benchmarks: read(ex, x, y) at 4096 random
/// points of the fixture's plane with input pixels of pitch_um; items are
/// reads.
template <class Read>
void time_exposure(benchmark::State& state, double pitch_um, Read&& read)
{
    static ExposureFixture fx;
    const LayerExposure ex(fx.view, { 0.2126, 0.7152, 0.0722 }, pitch_um, kNoSaturation,
                           FrameEdge::clamp);
    const auto centres = random_centres();
    size_t i   = 0;
    double sum = 0.0;
    for (auto _ : state) {
        const auto& c = centres[i++ & 4095];
        sum += read(ex, c.first, c.second);
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations());
}

void BM_ExposureDisc(benchmark::State& state)
{
    const double r_um = 0.5 * static_cast<double>(state.range(0)) / 4.0;  // 1 um pixels
    time_exposure(state, 1.0, [&](const LayerExposure& ex, double x, double y) {
        return ex.integrate_over_disc(x, y, r_um);
    });
}
// Disc diameter / input pixel = 0.25, 0.5, 1, 2, 4, 8.
BENCHMARK(BM_ExposureDisc)->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Arg(16)->Arg(32);

void BM_ExposureCentre(benchmark::State& state)
{
    time_exposure(state, 1.0, [](const LayerExposure& ex, double x, double y) {
        return ex.value_at(x, y) * M_PI;
    });
}
BENCHMARK(BM_ExposureCentre);

/// The fast kernel's exposure from its float plane (ExposurePlane) of the
/// same fixture, a cell's worth (64 discs) per call as the kernel calls it:
/// integrals_over_discs (disc diameter R/4 input pixels, R <= 4) and, for
/// comparison (R = 0), the centre lookup; items = discs.
void BM_ExposurePlaneDisc(benchmark::State& state)
{
    static ExposureFixture fx;
    const LayerExposure ex(fx.view, { 0.2126, 0.7152, 0.0722 }, 1.0, kNoSaturation,
                           FrameEdge::clamp);
    FrameGeometry frame;
    if (!FrameGeometry::make(256.0 / 1000.0, 256, 256, 256, 256, frame)) {
        state.SkipWithError("frame");
        return;
    }
    ExposurePlane plane;
    plane.fill(ex, frame, { 0.0, 0.0, 256.0, 256.0 });
    const auto centres = random_centres();
    std::vector<double> x, y, r, out(64);
    for (const auto& c : centres) {
        x.push_back(c.first);
        y.push_back(c.second);
        r.push_back(0.5 * static_cast<double>(state.range(0)) / 4.0);
    }
    size_t i   = 0;
    double sum = 0.0;
    for (auto _ : state) {
        const size_t o = (i++ * 64) & 4095;
        if (state.range(0) == 0)
            for (size_t j = 0; j < 64; ++j)
                out[j] = plane.at(x[o + j], y[o + j]) * M_PI * 0.25;
        else
            plane.integrals_over_discs(&x[o], &y[o], &r[o], 64, out.data());
        sum += out[0] + out[63];
    }
    benchmark::DoNotOptimize(sum);
    state.SetItemsProcessed(state.iterations() * 64);
}
// 0: the centre lookup; disc diameter / input pixel = 0.25, 0.5, 1.
BENCHMARK(BM_ExposurePlaneDisc)->Arg(0)->Arg(1)->Arg(2)->Arg(4);

/// Developed discs touching a 64 x 64 block of 6.25 um pixels: a Boolean
/// model of paper-stock discs (mean 6 um, log sigma 0.5) whose expected
/// covered fraction is c.
struct CoverageFixture {
    static constexpr int64_t kBlock = 64;
    static constexpr double kPitchUm = 6.25;
    std::vector<Disc> discs;
    explicit CoverageFixture(double covered_fraction)
    {
        Population pop;
        pop.diameter_um        = 6.0;
        pop.diameter_log_sigma = 0.5;
        const double a_mean    = M_PI / 4.0 * 36.0 * std::exp(0.25);
        pop.grains_per_um2     = -std::log(1.0 - covered_fraction) / a_mean;
        const PopulationGrains grains(pop, 3, 0, 0);
        const double side = kBlock * kPitchUm;
        grains.for_each_grain_near({ 0.0, 0.0, side, side }, [&](const Grain& g) {
            const Disc d { g.x_um, g.y_um, g.radius_um };
            if (disc_touches_rect(d, 0.0, 0.0, side, side))
                discs.push_back(d);
        });
    }
};

/// The loop of the coverage benchmarks: cover(fx, fraction) covers one
/// block of the fixture whose covered fraction is state.range(0) / 100;
/// items are discs.
template <class Cover>
void time_coverage(benchmark::State& state, Cover&& cover)
{
    const CoverageFixture fx(static_cast<double>(state.range(0)) / 100.0);
    std::vector<double> fraction(CoverageFixture::kBlock * CoverageFixture::kBlock);
    for (auto _ : state) {
        cover(fx, fraction.data());
        benchmark::DoNotOptimize(fraction.data());
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * fx.discs.size()));
    state.counters["discs"] = static_cast<double>(fx.discs.size());
}

constexpr int64_t kBlock   = CoverageFixture::kBlock;
constexpr double kPitchUm = CoverageFixture::kPitchUm;

void BM_GridCoverage(benchmark::State& state)
{
    GridCoverageScratch scratch;
    time_coverage(state, [&](const CoverageFixture& fx, double* fraction) {
        grid_coverage(fx.discs, 0, 0, kBlock, kBlock, kPitchUm, kPitchUm, scratch, fraction);
    });
}
// Covered fraction 0.1, 0.5, 0.8, 0.95 (density 0.05, 0.3, 0.7, 1.3).
BENCHMARK(BM_GridCoverage)->Arg(10)->Arg(50)->Arg(80)->Arg(95);

/// Scanline and raster coverage (the same arguments): state.range(1)
/// samples per pixel.
template <class Scratch>
using SampledCoverage = void (*)(const std::vector<Disc>&, int64_t, int64_t, int64_t, int64_t,
                                 double, double, int, Scratch&, double*);

template <class Scratch>
void time_sampled_coverage(benchmark::State& state, SampledCoverage<Scratch> cover)
{
    const int samples = static_cast<int>(state.range(1));
    Scratch scratch;
    time_coverage(state, [&](const CoverageFixture& fx, double* fraction) {
        cover(fx.discs, 0, 0, kBlock, kBlock, kPitchUm, kPitchUm, samples, scratch, fraction);
    });
}

void BM_ScanlineCoverage(benchmark::State& state)
{
    time_sampled_coverage<ScanlineScratch>(state, scanline_coverage);
}
BENCHMARK(BM_ScanlineCoverage)
    ->ArgsProduct({ { 10, 50, 80, 95 }, { 1, 4, 16 } });

void BM_RasterCoverage(benchmark::State& state)
{
    time_sampled_coverage<RasterScratch>(state, raster_coverage);
}
// 8 rows: fast's 4 per radius of the 6 um discs on 6.25 um pixels; 42: auto's
// 21 per radius at the default tolerance.
BENCHMARK(BM_RasterCoverage)->ArgsProduct({ { 10, 50, 80, 95 }, { 8, 42 } });

const DevelopTable& fast_table()
{
    static const DevelopTable table = [] {
        DevelopTable::Options o;
        o.max_photons           = 256;
        o.target_standard_error = 5e-3;
        return DevelopTable(kRates, kShutterS, Development(paper_like_stock()), o);
    }();
    return table;
}

void BM_FastKernel(benchmark::State& state)
{
    Population pop;
    pop.grains_per_um2     = 0.3;
    pop.diameter_um        = static_cast<double>(state.range(0)) / 10.0;
    pop.diameter_log_sigma = 0.35;
    const PopulationGrains grains(pop, 1, 0, 0);
    const FastGrains fast(grains);
    const DevelopCurve curve(fast_table());
    const double k = 20.0 / grains.mean_area_um2();
    const RectUm rect { 0.0, 0.0, 400.0, 400.0 };
    uint64_t n = 0;
    for (auto _ : state) {
        uint64_t developed = 0;
        fast.for_each_grain_near(rect, [&](double, double, double r, uint32_t bits, uint64_t) {
            ++n;
            developed += (bits + 0.5) * 0x1.0p-32 >= 1.0 - curve.probability(k * M_PI * r * r);
        });
        benchmark::DoNotOptimize(developed);
    }
    state.SetItemsProcessed(static_cast<int64_t>(n));
}
BENCHMARK(BM_FastKernel)->Arg(10)->Arg(35)->Arg(60);

void BM_PixelModelDraw(benchmark::State& state)
{
    Population pop;
    pop.grains_per_um2 = 12.0;
    pop.diameter_um    = 0.5;
    const DevelopCurve curve(fast_table());
    const PopulationGrains grains(pop, 1, 0, 0);
    const PixelModel model({ { &pop, &grains, 400.0, &curve, &fast_table() } }, 6.0, 6.0);
    std::vector<double> v(64 * 64), t(64 * 64);
    for (size_t i = 0; i < v.size(); ++i)
        v[i] = 0.01 * static_cast<double>(i % 100);
    for (auto _ : state) {
        sample_pixel_transmittance(model, 1, 0, 0, 64, 64, v.data(), nullptr, t.data());
        benchmark::DoNotOptimize(t.data());
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * 64 * 64));
}
BENCHMARK(BM_PixelModelDraw);

void BM_SpreadFrame(benchmark::State& state)
{
    const double frame_width_um = 1000.0 * SceneSettings().width_mm;  // Super 35
    const int64_t w = state.range(0), h = w * 3112 / 4096;
    const double pitch_um = frame_width_um / static_cast<double>(w);
    HalationSpec halo;
    halo.fraction              = 0.02;
    halo.kernel                = HalationKernel::base;
    halo.base_thickness_um     = 125.0;
    halo.base_refractive_index = 1.48;
    halo.rear_face             = RearFace::remjet;
    std::vector<double> values(static_cast<size_t>(w * h));
    for (size_t i = 0; i < values.size(); ++i)
        values[i] = 1.0 + 0.5 * std::sin(0.001 * static_cast<double>(i));
    for (auto _ : state) {
        std::vector<double> out = spread_frame(values, w, h, pitch_um, 0.3, 5.0, halo,
                                               FrameEdge::clamp);
        benchmark::DoNotOptimize(out.data());
    }
    state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * w * h));
}
BENCHMARK(BM_SpreadFrame)->Arg(1024)->Arg(4096)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace filmgrain

BENCHMARK_MAIN();
