// Tests of image formation (MODEL.md 5): exact union coverage and density.
#include "image_formation.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "rng.h"

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
