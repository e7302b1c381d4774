// Tests of image formation (MODEL.md 5): exact union coverage and density.
#include "model/image_formation.h"
#include "kernels/coverage_grid.h"
#include "kernels/coverage_scanline.h"

#include <cmath>
#include <iomanip>
#include <vector>

#include <gtest/gtest.h>

#include "util/rng.h"

namespace filmgrain {
namespace {

/// Covered area by midpoint sampling on an n x n grid. Only grid cells cut
/// by a circle can be wrong, so the error is at most the number of such
/// cells times the cell area: (sum of perimeters / cell side + 4 per
/// circle) * cell area, which the caller uses as its tolerance.
double grid_coverage(const std::vector<Disc>& discs, double w, double h, int n, double& bound)
{
    const double cx = w / n, cy = h / n;
    double covered = 0, perimeter = 0;
    for (const Disc& d : discs)
        perimeter += 2 * M_PI * d.r_um;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double x = (i + 0.5) * cx, y = (j + 0.5) * cy;
            for (const Disc& d : discs)
                if ((x - d.x_um) * (x - d.x_um) + (y - d.y_um) * (y - d.y_um) <= d.r_um * d.r_um) {
                    covered += 1;
                    break;
                }
        }
    const double cell = std::max(cx, cy);
    bound = (2 * perimeter / cell + 4.0 * discs.size()) * cx * cy;
    return covered * cx * cy;
}

TEST(UnionCoverage, EmptyAndFull)
{
    EXPECT_EQ(union_coverage_um2(nullptr, 0, 0, 0, 1, 1), 0.0);
    const Disc big { 0.5, 0.5, 1.0 };
    EXPECT_EQ(union_coverage_um2(&big, 1, 0, 0, 1, 1), 1.0);
}

TEST(UnionCoverage, DisjointDiscsAdd)
{
    const std::vector<Disc> d = { { 2, 2, 1 }, { 6, 2, 1.5 } };
    EXPECT_NEAR(union_coverage_um2(d.data(), 2, 0, 0, 10, 10), M_PI * (1 + 2.25), 1e-12);
}

TEST(UnionCoverage, NestedAndIdenticalDiscsCountOnce)
{
    const std::vector<Disc> nested = { { 5, 5, 1 }, { 5.2, 5, 3 } };
    EXPECT_NEAR(union_coverage_um2(nested.data(), 2, 0, 0, 10, 10), M_PI * 9, 1e-12);
    const std::vector<Disc> same = { { 5, 5, 2 }, { 5, 5, 2 }, { 5, 5, 2 } };
    EXPECT_NEAR(union_coverage_um2(same.data(), 3, 0, 0, 10, 10), M_PI * 4, 1e-12);
}

TEST(UnionCoverage, TwoOverlappingDiscsLens)
{
    // Two unit discs at distance 1: union = 2 pi - lens, lens = 2 acos(1/2) - sqrt(3)/2.
    const std::vector<Disc> d = { { 4, 4, 1 }, { 5, 4, 1 } };
    const double lens = 2 * std::acos(0.5) - std::sqrt(3.0) / 2;
    EXPECT_NEAR(union_coverage_um2(d.data(), 2, 0, 0, 10, 10), 2 * M_PI - lens, 1e-12);
}

TEST(UnionCoverage, RandomDiscsAgreeWithFineGrid)
{
    Rng rng(2024, Stage::cell);
    for (int trial = 0; trial < 20; ++trial) {
        std::vector<Disc> discs;
        const int n = 1 + static_cast<int>(rng.uniform() * 25);
        for (int i = 0; i < n; ++i)
            discs.push_back({ rng.uniform() * 14 - 2, rng.uniform() * 10 - 2,
                              0.2 + rng.uniform() * 3 });
        double bound    = 0;
        const double g  = grid_coverage(discs, 10, 6, 1500, bound);
        const double a  = union_coverage_um2(discs.data(), discs.size(), 0, 0, 10, 6);
        EXPECT_NEAR(a, g, bound) << "trial " << trial;
        EXPECT_GE(a, 0.0);
        EXPECT_LE(a, 60.0);
    }
}

TEST(UnionCoverage, DoesNotDependOnTheRectangleOrigin)
{
    // Same configuration shifted far away: the result changes only by
    // rounding (coordinates are taken relative to the rectangle).
    const std::vector<Disc> d = { { 1, 1, 1.2 }, { 2, 1.5, 0.7 }, { 0.3, 2, 0.9 } };
    std::vector<Disc> far = d;
    for (Disc& x : far) {
        x.x_um += 1e8;
        x.y_um += 1e8;
    }
    const double a = union_coverage_um2(d.data(), 3, 0, 0, 3, 3);
    const double b = union_coverage_um2(far.data(), 3, 1e8, 1e8, 1e8 + 3, 1e8 + 3);
    EXPECT_NEAR(a, b, 1e-6);
}

/// Random discs touching the block [bx0, bx1) x [by0, by1) of a px x py grid.
std::vector<Disc> random_discs(Rng& rng, int n, double bx0, double by0, double bx1, double by1,
                               double rmax)
{
    std::vector<Disc> discs;
    while (static_cast<int>(discs.size()) < n) {
        const Disc d { bx0 - rmax + rng.uniform() * (bx1 - bx0 + 2 * rmax),
                       by0 - rmax + rng.uniform() * (by1 - by0 + 2 * rmax),
                       0.05 + rng.uniform() * rmax };
        if (disc_touches_rect(d, bx0, by0, bx1, by1))
            discs.push_back(d);
    }
    return discs;
}

TEST(GridCoverage, EqualsThePerPixelUnionArea)
{
    // Two exact algorithms (per block, per pixel) must agree to rounding.
    Rng rng(77, Stage::cell);
    GridCoverageScratch scratch;
    for (int trial = 0; trial < 40; ++trial) {
        const double px = 0.5 + rng.uniform() * 3, py = 0.5 + rng.uniform() * 3;
        const int64_t x0 = static_cast<int64_t>(rng.uniform() * 20) - 10, y0 = 3;
        const int64_t x1 = x0 + 1 + static_cast<int64_t>(rng.uniform() * 9), y1 = y0 + 5;
        const int n      = 1 + static_cast<int>(rng.uniform() * 60);
        const auto discs = random_discs(rng, n, x0 * px, y0 * py, x1 * px, y1 * py,
                                        trial % 4 == 0 ? 12.0 : 2.5);
        std::vector<double> f((x1 - x0) * (y1 - y0));
        grid_coverage(discs, x0, y0, x1, y1, px, py, scratch, f.data());
        for (int64_t y = y0; y < y1; ++y)
            for (int64_t x = x0; x < x1; ++x) {
                const double exact = union_coverage_um2(discs.data(), discs.size(), x * px, y * py,
                                                        (x + 1) * px, (y + 1) * py)
                                     / (px * py);
                ASSERT_NEAR(f[(y - y0) * (x1 - x0) + (x - x0)], exact, 1e-9)
                    << "trial " << trial << " pixel " << x << "," << y;
            }
    }
}

TEST(GridCoverage, SameForAnyBlocking)
{
    // A pixel's fraction is bit-identical whether its block is large or
    // small (given the discs that touch each block, in the same order).
    Rng rng(5, Stage::cell);
    const double px = 1.3, py = 0.9;
    const auto all  = random_discs(rng, 400, 0, 0, 24 * px, 18 * py, 2.0);
    GridCoverageScratch scratch;
    std::vector<double> whole(24 * 18);
    grid_coverage(all, 0, 0, 24, 18, px, py, scratch, whole.data());
    for (int64_t by = 0; by < 18; by += 6)
        for (int64_t bx = 0; bx < 24; bx += 5) {
            const int64_t ex = std::min<int64_t>(bx + 5, 24), ey = std::min<int64_t>(by + 6, 18);
            std::vector<Disc> part;
            for (const Disc& d : all)
                if (disc_touches_rect(d, bx * px, by * py, ex * px, ey * py))
                    part.push_back(d);
            std::vector<double> f((ex - bx) * (ey - by));
            grid_coverage(part, bx, by, ex, ey, px, py, scratch, f.data());
            for (int64_t y = by; y < ey; ++y)
                for (int64_t x = bx; x < ex; ++x)
                    ASSERT_EQ(f[(y - by) * (ex - bx) + (x - bx)], whole[y * 24 + x])
                        << x << "," << y << " block " << bx << "," << by << std::setprecision(17) << " " << f[(y - by) * (ex - bx) + (x - bx)] - whole[y * 24 + x];
        }
}

TEST(ScanlineCoverage, ConvergesToTheExactFraction)
{
    // Midpoint sampling in y of exact chord unions: the error shrinks as
    // sub-scanlines are added.
    Rng rng(8, Stage::cell);
    const double px = 2.0, py = 2.0;
    const auto discs = random_discs(rng, 300, 0, 0, 20 * px, 10 * py, 1.5);
    GridCoverageScratch gs;
    std::vector<double> exact(200), approx(200);
    grid_coverage(discs, 0, 0, 20, 10, px, py, gs, exact.data());
    ScanlineScratch ss;
    double prev = 1e9;
    for (int samples : { 2, 8, 32, 128 }) {
        scanline_coverage(discs, 0, 0, 20, 10, px, py, samples, ss, approx.data());
        double rms = 0;
        for (size_t i = 0; i < exact.size(); ++i)
            rms += (approx[i] - exact[i]) * (approx[i] - exact[i]);
        rms = std::sqrt(rms / exact.size());
        EXPECT_LT(rms, prev) << samples;
        prev = rms;
    }
    EXPECT_LT(prev, 2e-3);
}

TEST(Density, FromTransmittance)
{
    EXPECT_DOUBLE_EQ(density_from_transmittance(1.0, 4.0, 0.2), 0.2);
    EXPECT_NEAR(density_from_transmittance(0.1, 4.0, 0.0), 1.0, 1e-15);
    EXPECT_DOUBLE_EQ(density_from_transmittance(0.0, 3.0, 0.1), 3.1);   // clamp
    EXPECT_DOUBLE_EQ(density_from_transmittance(-1e-17, 3.0, 0.0), 3.0);
}

TEST(DiscTouchesRect, Basic)
{
    EXPECT_TRUE(disc_touches_rect({ 0.5, 0.5, 0.1 }, 0, 0, 1, 1));
    EXPECT_TRUE(disc_touches_rect({ -0.5, 0.5, 0.6 }, 0, 0, 1, 1));
    EXPECT_FALSE(disc_touches_rect({ -0.5, -0.5, 0.7 }, 0, 0, 1, 1));  // corner: 0.707
    EXPECT_TRUE(disc_touches_rect({ -0.5, -0.5, 0.71 }, 0, 0, 1, 1));
}

}  // namespace
}  // namespace filmgrain
