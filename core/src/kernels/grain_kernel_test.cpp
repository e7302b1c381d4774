// Tests of the fast per-grain kernel's parts against the model: the folded
// curve P(develop | lambda) against a Poisson mixture computed
// independently and against sampled photon counts, the fast grain process
// against its intensity and size distribution, the exposure plane, and the
// raster coverage against exact coverage.
#include "kernels/grain_kernel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "expect/develop_curve.h"
#include "model/image_formation.h"
#include "kernels/coverage_grid.h"
#include "kernels/coverage_raster.h"
#include "engine/kinetics_table.h"
#include "util/sampling.h"
#include "testing/test_tables.h"

namespace filmgrain {
namespace {

TEST(DevelopCurve, IsThePoissonMixtureOfTheTable)
{
    const DevelopTable table = small_develop_table();
    const DevelopCurve curve(table);
    EXPECT_GT(curve.lambda_max(), 100.0);
    EXPECT_LT(curve.lambda_max(), 256.0);
    EXPECT_LT(curve.max_interpolation_error(), 1e-4);
    // Independent sum: the Poisson pmf from lgamma, every N to the table's
    // top (the curve's own sum uses a recurrence and a window).
    for (double lambda : { 0.0, 0.3, 2.0, 4.5, 11.0, 37.0, 80.0, curve.lambda_max() }) {
        double sum = 0.0;
        for (uint64_t n = 0; n <= table.max_photons(); ++n) {
            const double pmf = lambda > 0.0
                                   ? std::exp(n * std::log(lambda) - lambda - std::lgamma(n + 1.0))
                                   : (n == 0 ? 1.0 : 0.0);
            sum += pmf * table.probability(n);
        }
        EXPECT_NEAR(curve.probability(lambda), sum, curve.max_interpolation_error() + 1e-12)
            << "lambda " << lambda;
    }
}

TEST(DevelopCurve, OneUniformAgainstTheCurveDevelopsLikeSampledPhotonCounts)
{
    // The fast kernel's decision (u >= 1 - P(lambda)) against the table
    // path's (N ~ Poisson(lambda), then u >= 1 - P(N)): the fractions
    // developed of M grains each differ by a binomial sd sqrt(2 p (1 - p) / M);
    // 5 sd.
    const DevelopTable table = small_develop_table();
    const DevelopCurve curve(table);
    constexpr int M = 200000;
    for (double lambda : { 3.0, 12.0, 40.0 }) {
        int by_curve = 0, by_count = 0;
        for (int i = 0; i < M; ++i) {
            Rng a(hash_ids(7, i), Stage::development), b(hash_ids(8, i), Stage::photons);
            by_curve += a.uniform() >= 1.0 - curve.probability(lambda);
            const uint64_t n = sample_poisson(lambda, b);
            by_count += b.uniform() >= 1.0 - table.probability(n);
        }
        const double p  = 0.5 * (by_curve + by_count) / M;
        const double sd = std::sqrt(2.0 * p * (1.0 - p) / M);
        EXPECT_NEAR(static_cast<double>(by_curve) / M, static_cast<double>(by_count) / M, 5 * sd)
            << "lambda " << lambda;
    }
}

TEST(FastGrains, IntensityAndSizesFollowThePopulation)
{
    Population pop;
    pop.grains_per_um2     = 0.4;
    pop.diameter_um        = 2.0;
    pop.diameter_log_sigma = 0.5;  // several radius bins
    const PopulationGrains grains(pop, 11, 0, 0);
    ASSERT_GT(grains.bins().size(), 1u);
    const FastGrains fast(grains);
    // The tabulated quantiles move the mean disc area (hence densities)
    // by far less than any test resolves.
    EXPECT_LT(fast.mean_area_relative_error(), 1e-4);
    // Grains with centres in a 400 um square: count ~ Poisson(n A): 5 sd;
    // mean disc area against a_mean: 5 standard errors of the sample mean.
    const RectUm rect { 0.0, 0.0, 400.0, 400.0 };
    uint64_t count = 0;
    double sum_a = 0.0, sum_a2 = 0.0;
    fast.for_each_grain_near(rect, [&](double x, double y, double r, uint32_t, uint64_t) {
        if (x < rect.x0_um || x >= rect.x1_um || y < rect.y0_um || y >= rect.y1_um)
            return;
        ++count;
        const double a = M_PI * r * r;
        sum_a += a;
        sum_a2 += a * a;
    });
    const double expected = pop.grains_per_um2 * 400.0 * 400.0;
    EXPECT_NEAR(static_cast<double>(count), expected, 5 * std::sqrt(expected));
    const double mean = sum_a / count;
    const double se   = std::sqrt((sum_a2 / count - mean * mean) / count);
    EXPECT_NEAR(mean, grains.mean_area_um2(), 5 * se);
}

TEST(FastGrains, ACellsGrainsDoNotDependOnTheRegionAsked)
{
    Population pop;
    const PopulationGrains grains(pop, 5, 1, 0);
    const FastGrains fast(grains);
    std::vector<std::array<double, 3>> a, b;
    fast.for_each_grain_near({ 0, 0, 100, 100 }, [&](double x, double y, double r, uint32_t, uint64_t) {
        if (x >= 40 && x < 60 && y >= 40 && y < 60)
            a.push_back({ x, y, r });
    });
    fast.for_each_grain_near({ 40, 40, 60, 60 }, [&](double x, double y, double r, uint32_t, uint64_t) {
        if (x >= 40 && x < 60 && y >= 40 && y < 60)
            b.push_back({ x, y, r });
    });
    EXPECT_FALSE(a.empty());
    EXPECT_EQ(a, b);
}

TEST(DevelopCurve, ProbabilityBoundHoldsOverEveryLowerMean)
{
    // The grain filter's bound (tile_renderer.cpp): probability_bound_at_-
    // root(sqrt(l)) >= probability(l') for every l' <= l, on a grid 16
    // times finer than the nodes (the running maximum taken on that grid);
    // 1 beyond lambda_max, where grains need their count.
    const DevelopTable table = small_develop_table();
    const DevelopCurve curve(table);
    const double root_max = std::sqrt(curve.lambda_max());
    const int steps       = 16 * static_cast<int>(curve.node_count());
    double running        = 0.0;
    for (int i = 0; i <= steps; ++i) {
        const double s = root_max * i / steps;
        running        = std::max(running, curve.probability(s * s));
        ASSERT_GE(curve.probability_bound_at_root(s), running) << "lambda " << s * s;
        // Not a loose bound: at most the curve's largest value up to two
        // node steps further.
        const double ahead = std::min(root_max, s + 2.0 * root_max / curve.node_count());
        ASSERT_LE(curve.probability_bound_at_root(s),
                  std::max(running, curve.probability(ahead * ahead)) + 1e-12);
    }
    EXPECT_EQ(curve.probability_bound_at_root(std::sqrt(curve.lambda_max() * 1.0001)), 1.0);
    EXPECT_EQ(curve.probability_bound_at_root(std::numeric_limits<double>::infinity()), 1.0);
    EXPECT_EQ(curve.probability_bound_at_root(std::nan("")), 1.0);
}

TEST(FastGrains, AFilterKeepsTheSameGrainsAndCountsTheRest)
{
    // A filtered batch holds exactly the unfiltered batch's grains that
    // the filter keeps (positions, radii, bits, identities, order), and
    // drawn_within counts every drawn grain, kept or not, for rectangles
    // that hold a cell wholly, miss it or cut it.
    Population pop;
    pop.diameter_log_sigma = 0.5;
    const PopulationGrains grains(pop, 11, 0, 2);
    const FastGrains fast(grains);
    const RectUm region { 3.0, 5.0, 23.0, 19.0 };
    const double median_r = grains.radius_at_z_um(0.0);
    // Some bits keep a grain whatever its radius, some only large grains,
    // the rest none (may_keep false: their radius is never drawn).
    const auto keep = [&](double r_um, uint32_t u_bits) {
        return (u_bits & 3u) == 0 || (r_um > median_r && (u_bits & 4u) == 0);
    };
    struct Kept {
        double x, y, r;
        uint32_t u;
        uint64_t id;
        bool operator==(const Kept& o) const
        {
            return x == o.x && y == o.y && r == o.r && u == o.u && id == o.id;
        }
    };
    std::vector<Kept> all_kept, filtered;
    std::vector<size_t> drawn_all, drawn_filtered;
    const std::vector<RectUm> rects = { region, { 0.0, 0.0, 1000.0, 1000.0 },
                                        { 7.3, 8.1, 9.9, 12.2 }, { 500.0, 500.0, 600.0, 600.0 } };
    std::vector<size_t> within_all(rects.size()), within_filtered(rects.size());
    FastGrains::Batch batch;
    fast.for_each_cell_batch(region, batch, [&](const FastGrains::Batch& b) {
        drawn_all.push_back(b.drawn);
        for (size_t i = 0; i < b.n; ++i)
            if (keep(b.r[i], b.u_bits[i]))
                all_kept.push_back({ b.x[i], b.y[i], b.r[i], b.u_bits[i], b.grain_id(i) });
        for (size_t k = 0; k < rects.size(); ++k)
            within_all[k] += fast.drawn_within(b, rects[k]);
    });
    struct Keep {
        const decltype(keep)& f;
        explicit operator bool() const { return true; }
        bool may_keep(uint32_t u) const { return (u & 3u) == 0 || (u & 4u) == 0; }
        bool operator()(double r, uint32_t u) const { return f(r, u); }
    };
    fast.for_each_cell_batch(
        region, 1.0, batch, [&](size_t, int64_t, int64_t) { return Keep { keep }; },
        [&](const FastGrains::Batch& b) {
            drawn_filtered.push_back(b.drawn);
            for (size_t i = 0; i < b.n; ++i)
                filtered.push_back({ b.x[i], b.y[i], b.r[i], b.u_bits[i], b.grain_id(i) });
            for (size_t k = 0; k < rects.size(); ++k)
                within_filtered[k] += fast.drawn_within(b, rects[k]);
        });
    EXPECT_EQ(drawn_all, drawn_filtered);
    ASSERT_GT(all_kept.size(), 100u);
    EXPECT_EQ(all_kept, filtered);
    EXPECT_EQ(within_all, within_filtered);
    EXPECT_GT(within_all[2], 0u);
    EXPECT_EQ(within_all[3], 0u);
}

TEST(ExposurePlane, DiscIntegralIsTheBoxImagesIntegral)
{
    // A 9x7 image of random values (some zero) at a 10 um pitch; the
    // plane's disc integral against LayerExposure's (exact, from the
    // quadrant function) for discs up to a pixel in radius (both of its
    // formulas: up to half a pixel, and up to a pixel) anywhere over and
    // beside the image: at pixel edges, corners, inside pixels, half
    // outside. Tolerance: the segment table's error times r^2 for
    // each of the two edges, weighted by the largest value, plus the
    // plane's float rounding (relative 2^-24 of the integral's scale).
    constexpr int64_t W = 9, H = 7;
    constexpr double kPitch = 10.0;
    std::mt19937_64 gen(42);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<float> px(W * H);
    for (float& v : px)
        v = unit(gen) < 0.2 ? 0.0f : static_cast<float>(4.0 * unit(gen));
    const ImageView view { px.data(), W, H, 1 };
    const LayerExposure exposure(view, { 1.0, 0.0, 0.0 }, kPitch, 1e30, FrameEdge::gate);
    FrameGeometry frame;
    ASSERT_TRUE(FrameGeometry::make(W * kPitch / 1000.0, W, H, W, H, frame));
    ExposurePlane plane;
    plane.fill(exposure, frame, { -20.0, -20.0, W * kPitch + 20.0, H * kPitch + 20.0 });
    ASSERT_DOUBLE_EQ(plane.pitch_um(), kPitch);
    const double seg_error = SegmentTable::shared().max_error();
    EXPECT_GT(seg_error, 0.0);
    EXPECT_LT(seg_error, 1e-5);
    int straddling = 0, corners = 0, both_sides = 0;
    for (int i = 0; i < 20000; ++i) {
        const double x = -8.0 + (W * kPitch + 16.0) * unit(gen);
        const double y = -8.0 + (H * kPitch + 16.0) * unit(gen);
        // Radii down to tiny, up to exactly half the pitch; every tenth
        // disc centred on a corner or an edge exactly.
        double r = i % 7 == 0 ? 0.5 * kPitch : i % 11 == 0 ? kPitch : kPitch * unit(gen);
        double cx = x, cy = y;
        if (i % 10 == 0)
            cx = kPitch * std::round(x / kPitch);
        if (i % 20 == 0)
            cy = kPitch * std::round(y / kPitch);
        r = std::max(r, 1e-3);
        const double want = exposure.integrate_over_disc(cx, cy, r);
        const double got  = plane.integral_over_disc(cx, cy, r);
        const double tol  = 4.0 * seg_error * r * r * 4.0 + 4.0 * M_PI * r * r * 0x1.0p-22;
        ASSERT_NEAR(got, want, tol) << "disc (" << cx << ", " << cy << ") r " << r;
        const double fx = cx / kPitch - std::floor(cx / kPitch);
        const double fy = cy / kPitch - std::floor(cy / kPitch);
        const double ex = std::min(fx, 1.0 - fx) * kPitch, ey = std::min(fy, 1.0 - fy) * kPitch;
        straddling += ex < r || ey < r;
        corners += ex * ex + ey * ey < r * r;
        both_sides += fx * kPitch < r && (1.0 - fx) * kPitch < r;
    }
    // The cases the formula distinguishes all occurred.
    EXPECT_GT(straddling, 5000);
    EXPECT_GT(corners, 1000);
    EXPECT_GT(both_sides, 500);
}

TEST(ExposurePlane, EveryBuildGivesTheSameDiscIntegrals)
{
    // The batch (the AVX2 loop where the processor has it, four at a time,
    // and its scalar tail) against the portable loop: the same bits, for
    // discs inside, astride edges and corners, beside and far beyond the
    // window (those get a wrong value, but the same one and no read
    // outside the plane: the sanitizer run checks that).
    constexpr int64_t W = 13, H = 11;
    std::mt19937_64 gen(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<float> px(W * H);
    for (float& v : px)
        v = static_cast<float>(3.0 * unit(gen));
    const ImageView view { px.data(), W, H, 1 };
    const LayerExposure exposure(view, { 1.0, 0.0, 0.0 }, 6.0, 1e30, FrameEdge::gate);
    FrameGeometry frame;
    ASSERT_TRUE(FrameGeometry::make(W * 6.0 / 1000.0, W, H, W, H, frame));
    ExposurePlane plane;
    plane.fill(exposure, frame, { 12.0, 12.0, 50.0, 40.0 });
    std::vector<double> x, y, r;
    for (int i = 0; i < 4003; ++i) {
        const double spread = i % 50 == 0 ? 1e12 : 90.0;
        x.push_back(-10.0 + spread * unit(gen));
        y.push_back(-10.0 + spread * unit(gen));
        r.push_back(i % 9 == 0 ? 3.0 : 3.0 * unit(gen) + 1e-9);
    }
    std::vector<double> batch(x.size()), portable(x.size());
    plane.integrals_over_discs(x.data(), y.data(), r.data(), x.size(), batch.data());
    plane.integrals_over_discs(x.data(), y.data(), r.data(), x.size(), portable.data(), true);
    for (size_t i = 0; i < x.size(); ++i)
        ASSERT_EQ(std::memcmp(&batch[i], &portable[i], sizeof(double)), 0)
            << "disc " << i << ": " << batch[i] << " against " << portable[i];
}

TEST(RasterCoverage, ALoneDiscCoversItsArea)
{
    // A disc inside a 4x4 block of 10 um pixels: the rows sample its chord
    // (midpoint rule in y, 1/64 pixel in x). Error of the midpoint rule on
    // a disc of radius r with spacing h: O(h^1.5 r^0.5) near the poles;
    // here within 0.5% of the area at 64 rows.
    const std::vector<Disc> discs { { 17.3, 21.9, 8.1 } };
    RasterScratch scratch;
    std::vector<double> f(16);
    raster_coverage(discs, 0, 0, 4, 4, 10.0, 10.0, 64, scratch, f.data());
    double area = 0.0;
    for (double v : f)
        area += v * 100.0;
    EXPECT_NEAR(area, M_PI * 8.1 * 8.1, 0.005 * M_PI * 8.1 * 8.1);
}

TEST(RasterCoverage, UnbiasedAgainstExactCoverageAndTileIndependent)
{
    // Random discs over 64x64 pixels: the mean covered fraction of the
    // raster against exact coverage of the same discs. Pixel by pixel
    // they differ by the sampling error; the mean of the differences over
    // the pixels has a standard error from their spread; 5 of them.
    std::mt19937_64 gen(1);
    std::uniform_real_distribution<double> pos(-3.0, 131.0), rad(0.5, 2.5);
    std::vector<Disc> discs;
    for (int i = 0; i < 4000; ++i)
        discs.push_back({ pos(gen), pos(gen), rad(gen) });
    std::vector<Disc> touching;
    for (const Disc& d : discs)
        if (disc_touches_rect(d, 0, 0, 128, 128))
            touching.push_back(d);
    std::vector<double> exact(64 * 64), raster(64 * 64), tiled(64 * 64);
    GridCoverageScratch gs;
    grid_coverage(touching, 0, 0, 64, 64, 2.0, 2.0, gs, exact.data());
    RasterScratch rs;
    raster_coverage(touching, 0, 0, 64, 64, 2.0, 2.0, 8, rs, raster.data());
    double sum = 0.0, sum2 = 0.0;
    for (size_t i = 0; i < exact.size(); ++i) {
        const double d = raster[i] - exact[i];
        sum += d;
        sum2 += d * d;
    }
    const double n = static_cast<double>(exact.size());
    const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
    EXPECT_GT(se, 0.0);
    EXPECT_NEAR(mean, 0.0, 5 * se);
    // A block rendered as four tiles is the same, bit for bit.
    for (int ty = 0; ty < 2; ++ty)
        for (int tx = 0; tx < 2; ++tx) {
            std::vector<double> part(32 * 32);
            raster_coverage(touching, tx * 32, ty * 32, tx * 32 + 32, ty * 32 + 32, 2.0, 2.0, 8, rs,
                            part.data());
            for (int y = 0; y < 32; ++y)
                for (int x = 0; x < 32; ++x)
                    tiled[static_cast<size_t>((ty * 32 + y) * 64 + tx * 32 + x)]
                        = part[static_cast<size_t>(y * 32 + x)];
        }
    EXPECT_EQ(tiled, raster);
}

/// `count` discs with centres uniform in [lo, hi]^2 and radii 0.05 +
/// r_max u^3: most far below a pixel, some several pixels wide.
std::vector<Disc> random_discs(uint64_t seed, double lo, double hi, int count, double r_max)
{
    std::mt19937_64 gen(seed);
    std::uniform_real_distribution<double> pos(lo, hi), unit(0.0, 1.0);
    std::vector<Disc> discs;
    for (int i = 0; i < count; ++i)
        discs.push_back({ pos(gen), pos(gen), 0.05 + r_max * std::pow(unit(gen), 3.0) });
    return discs;
}

/// A block of covered fractions that is neither empty nor full (so that a
/// comparison of two of them tests something).
void expect_partly_covered(const std::vector<double>& fraction)
{
    double mean = 0.0;
    for (double v : fraction)
        mean += v / static_cast<double>(fraction.size());
    EXPECT_GT(mean, 0.1);
    EXPECT_LT(mean, 0.99);
}

TEST(RasterCoverage, CoversThePointsOfEachDiscsRowSpans)
{
    // Against a plain reference: a byte per sample point, each disc's span
    // on each sample row (the same row range and span arithmetic as
    // raster_coverage, documented in image_formation.h) marked point by
    // point, then counted per pixel. Discs from far below a pixel to
    // several pixels wide (runs within a word, across words, wider than
    // the four-word window) and discs cut by the block's edges, so that
    // how raster_coverage sets its bits (windows of words, masks, padding)
    // must give exactly the points of the spans, in every build.
    const std::vector<Disc> discs = random_discs(11, 60.0, 260.0, 1500, 14.0);
    const int64_t x0 = 25, y0 = 20, x1 = 65, y1 = 50;  // 3.1 x 3.7 um pixels
    const double px = 3.1, py = 3.7;
    for (int samples : { 1, 7, 42 }) {
        const int64_t cols = (x1 - x0) * 64, rows = (y1 - y0) * samples;
        const int64_t gx0 = x0 * 64, gy0 = y0 * samples;
        const double hy = py / samples, inv_hx = 64.0 / px, inv_hy = samples / py;
        std::vector<unsigned char> point(static_cast<size_t>(cols * rows), 0);
        for (const Disc& d : discs) {
            const int64_t ga = std::max<int64_t>(
                gy0, static_cast<int64_t>(std::ceil((d.y_um - d.r_um) * inv_hy - 0.5)));
            const int64_t gb = std::min<int64_t>(
                gy0 + rows - 1, static_cast<int64_t>(std::floor((d.y_um + d.r_um) * inv_hy - 0.5)));
            for (int64_t g = ga; g <= gb; ++g) {
                const double dy   = (static_cast<double>(g) + 0.5) * hy - d.y_um;
                const double half = std::sqrt(std::max(d.r_um * d.r_um - dy * dy, 0.0)) * inv_hx;
                const double xc   = d.x_um * inv_hx - 0.5;
                const int64_t ka  = std::max<int64_t>(static_cast<int64_t>(std::ceil(xc - half)), gx0);
                const int64_t kb  = std::min<int64_t>(static_cast<int64_t>(std::floor(xc + half)),
                                                     gx0 + cols - 1);
                for (int64_t k = ka; k <= kb; ++k)
                    point[static_cast<size_t>((g - gy0) * cols + (k - gx0))] = 1;
            }
        }
        std::vector<double> want(static_cast<size_t>((x1 - x0) * (y1 - y0)));
        for (int64_t iy = 0; iy < y1 - y0; ++iy)
            for (int64_t ix = 0; ix < x1 - x0; ++ix) {
                int count = 0;
                for (int64_t j = 0; j < samples; ++j)
                    for (int64_t c = 0; c < 64; ++c)
                        count += point[static_cast<size_t>((iy * samples + j) * cols + ix * 64 + c)];
                want[static_cast<size_t>(iy * (x1 - x0) + ix)] = count * (1.0 / (64.0 * samples));
            }
        for (bool portable : { false, true }) {
            std::vector<double> got(want.size());
            RasterScratch rs;
            rs.portable = portable;
            raster_coverage(discs, x0, y0, x1, y1, px, py, samples, rs, got.data());
            EXPECT_EQ(got, want) << samples << " rows per pixel, portable " << portable;
        }
        expect_partly_covered(want);
    }
}

TEST(RasterCoverage, EveryBuildGivesTheSameBits)
{
    // The AVX2 build (where the processor has it) against the portable one:
    // the same points covered, so the same fractions, for discs from far
    // below a pixel to several pixels wide (runs within a word, across two,
    // across many), on a block away from the origin.
    const std::vector<Disc> discs = random_discs(7, 90.0, 230.0, 3000, 12.0);
    for (int samples : { 1, 7, 42, 256 }) {
        std::vector<double> fast(40 * 30), portable(40 * 30);
        RasterScratch rs;
        raster_coverage(discs, 25, 20, 65, 50, 3.1, 3.7, samples, rs, fast.data());
        rs.portable = true;
        raster_coverage(discs, 25, 20, 65, 50, 3.1, 3.7, samples, rs, portable.data());
        EXPECT_EQ(fast, portable) << samples << " rows per pixel";
        expect_partly_covered(fast);
    }
}

}  // namespace
}  // namespace filmgrain
