// Tests of a sampled pixel law's shape as the pixel kernel draws it: its
// standardisation and its copula correlation, against draws of standard
// normals (tolerances from the sampling variance). The shape sampled from
// the model is held against grains rendered by the fast kernel in
// pixel_model_test.cpp.
#include "kernels/pixel_shape.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "util/rng.h"
#include "util/sampling.h"

namespace filmgrain {
namespace {

/// A strongly right-skewed shape: the quantiles of an exponential law at
/// the shape's scores (a sparse layer's pixels are skewed like it).
PixelShape exponential_shape()
{
    PixelShape s {};
    for (int j = 0; j < kShapeNodes; ++j)
        s[static_cast<size_t>(j)] = -std::log(normal_upper_tail(-kShapeZMax + j * kShapeZStep));
    return s;
}

TEST(PixelShape, ValueIsLinearBetweenNodesAndHeldBeyond)
{
    const PixelShape s = exponential_shape();
    EXPECT_EQ(shape_value(s, -kShapeZMax), s[0]);
    EXPECT_EQ(shape_value(s, -9.0), s[0]);
    EXPECT_EQ(shape_value(s, 9.0), s[kShapeNodes - 1]);
    const double z = -kShapeZMax + 5.25 * kShapeZStep;
    EXPECT_NEAR(shape_value(s, z), 0.75 * s[5] + 0.25 * s[6], 1e-15);
}

// S(Z) of a standardised shape has mean 0 and variance 1: checked on 2^20
// standard normals, within 5 standard errors (the mean's sd / sqrt(n); the
// variance's sqrt((m4 - 1) / n), m4 the sample's fourth moment).
TEST(PixelShape, StandardisedShapeHasMeanZeroAndVarianceOne)
{
    PixelShape s = exponential_shape();
    standardise_shape(s);
    Rng rng(hash_ids(7, 1), Stage::cell);
    constexpr int kN = 1 << 20;
    double m1 = 0.0, m2 = 0.0, m4 = 0.0;
    for (int i = 0; i < kN; ++i) {
        const double x = shape_value(s, normal_quantile(rng.uniform_open0()));
        m1 += x;
        m2 += x * x;
        m4 += x * x * x * x;
    }
    m1 /= kN;
    m2 /= kN;
    m4 /= kN;
    EXPECT_NEAR(m1, 0.0, 5.0 / std::sqrt(kN));
    EXPECT_NEAR(m2, 1.0, 5.0 * std::sqrt((m4 - 1.0) / kN));
    PixelShape flat {};
    flat.fill(0.25);
    standardise_shape(flat);
    for (double x : flat)
        EXPECT_EQ(x, 0.0);
}

// Two skewed draws whose normals have shape_normal_correlation(rho) have
// correlation rho: 2^19 pairs at each rho, within 5 standard errors of a
// sample correlation ((1 - rho^2) / sqrt(n), inflated 3x for the skewed
// law's heavier tail) plus the Hermite series' truncation (the variance
// beyond the sixth order bounds it; here below 1e-3).
TEST(PixelShape, NormalCorrelationGivesTheDrawsTheirCorrelation)
{
    PixelShape s = exponential_shape();
    standardise_shape(s);
    constexpr int kN = 1 << 19;
    for (double rho : { 0.05, 0.3, 0.7 }) {
        const double r = shape_normal_correlation(s, rho);
        EXPECT_GT(r, rho);  // a skewed law bends the normals' correlation down
        Rng rng(hash_ids(7, 2, static_cast<uint64_t>(rho * 100)), Stage::cell);
        double sxy = 0.0, sxx = 0.0, syy = 0.0, sx = 0.0, sy = 0.0;
        for (int i = 0; i < kN; ++i) {
            const double z1 = normal_quantile(rng.uniform_open0());
            const double w  = normal_quantile(rng.uniform_open0());
            const double x  = shape_value(s, z1);
            const double y  = shape_value(s, r * z1 + std::sqrt(1.0 - r * r) * w);
            sx += x;
            sy += y;
            sxy += x * y;
            sxx += x * x;
            syy += y * y;
        }
        const double n = kN;
        const double c = (sxy / n - sx * sy / (n * n))
                         / std::sqrt((sxx / n - sx * sx / (n * n)) * (syy / n - sy * sy / (n * n)));
        EXPECT_NEAR(c, rho, 5.0 * 3.0 * (1.0 - rho * rho) / std::sqrt(n) + 1e-3) << rho;
    }
    EXPECT_EQ(shape_normal_correlation(s, 0.0), 0.0);
    EXPECT_EQ(shape_normal_correlation(s, 1.0), 1.0);
}

}  // namespace
}  // namespace filmgrain
