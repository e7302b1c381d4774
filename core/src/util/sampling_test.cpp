// Tests of the sampling functions against their distributions.
#include "util/sampling.h"

#include <cmath>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

namespace filmgrain {
namespace {

TEST(Sampling, NormalQuantileInvertsTheCdf)
{
    // AS241 is accurate to ~1e-16 relative; erfc to a few ulp.
    for (double p : { 1e-300, 1e-50, 1e-19, 1e-10, 1e-4, 0.01, 0.2, 0.425, 0.5, 0.7, 0.975,
                      0.999, 1 - 1e-10 }) {
        const double z = normal_quantile(p);
        EXPECT_NEAR(normal_cdf(z) / p, 1.0, 1e-12) << "p = " << p;
    }
    EXPECT_EQ(normal_quantile(0.5), 0.0);
    EXPECT_NEAR(normal_quantile(0.975), 1.959963984540054, 1e-14);
    EXPECT_TRUE(std::isinf(normal_quantile(0.0)));
    EXPECT_TRUE(std::isinf(normal_quantile(1.0)));
}

TEST(Sampling, BatchQuantilesEqualTheScalarOnes)
{
    // normal_quantiles against normal_quantile, bit for bit: both regions,
    // the boundaries between them, and the limits.
    std::vector<double> p { 0.0, 1.0, 0.075, 0.925, std::nextafter(0.075, 0.0),
                            std::nextafter(0.925, 1.0), 1e-300, 0.5, 1 - 1e-16, std::nan("") };
    for (int i = 0; i < 20000; ++i)
        p.push_back((i + 0.5) / 20000.0);
    std::vector<double> z(p.size());
    normal_quantiles(p.data(), z.data(), p.size());
    for (size_t i = 0; i < p.size(); ++i) {
        const double want = normal_quantile(p[i]);
        EXPECT_TRUE(z[i] == want || (std::isnan(z[i]) && std::isnan(want)))
            << "p = " << p[i] << ": " << z[i] << " against " << want;
    }
}

TEST(Sampling, UpperTailIsAccurate)
{
    EXPECT_NEAR(normal_upper_tail(9.0) / 1.1285884059538408e-19, 1.0, 1e-12);
    for (double q : { 1e-19, 1e-12, 1e-5 })
        EXPECT_NEAR(normal_upper_tail(-normal_quantile(q)) / q, 1.0, 1e-12);
}

TEST(Sampling, TruncatedNormalStaysInItsBin)
{
    for (double u : { 0.0, 1e-12, 0.3, 0.999999 }) {
        const double lo = sample_truncated_normal(-INFINITY, 3.0, u);
        EXPECT_LE(lo, 3.0);
        const double hi = sample_truncated_normal(5.3, 7.6, u);
        EXPECT_GE(hi, 5.3);
        EXPECT_LE(hi, 7.6);
    }
    // u = 0.5 in an upper bin is its median: Q(z) halfway between the ends.
    const double z = sample_truncated_normal(5.0, 6.0, 0.5);
    const double q = 0.5 * (normal_upper_tail(5.0) + normal_upper_tail(6.0));
    EXPECT_NEAR(normal_upper_tail(z) / q, 1.0, 1e-10);
}

/// Mean and variance of n Poisson draws. The sample mean's standard error
/// is sqrt(mean / n); the sample variance's is about mean * sqrt(2 / n)
/// (plus a kurtosis term 1/mean, negligible here). Tolerances: 5 sigma.
void check_poisson_moments(double mean, int n)
{
    Rng rng(hash_ids(42, static_cast<uint64_t>(mean * 1000)), Stage::photons);
    // Accumulate deviations from the true mean: k^2 would lose all
    // precision at mean 1e12.
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
        const double d = static_cast<double>(sample_poisson(mean, rng)) - mean;
        sum += d;
        sum2 += d * d;
    }
    const double m = mean + sum / n, var = sum2 / n - (sum / n) * (sum / n);
    EXPECT_NEAR(m, mean, 5 * std::sqrt(mean / n)) << "mean " << mean;
    EXPECT_NEAR(var, mean, 5 * mean * std::sqrt((2.0 + 1.0 / mean) / n)) << "mean " << mean;
}

TEST(Sampling, PoissonMoments)
{
    for (double mean : { 0.01, 0.7, 3.0, 9.99, 10.0, 31.4, 1e3, 1e7, 1e12 })
        check_poisson_moments(mean, 200000);
}

TEST(Sampling, PoissonMatchesItsPmf)
{
    // Chi-square goodness of fit on the cells with expected count >= 20.
    // With k cells the statistic has mean k - 1 and sd sqrt(2(k - 1)); we
    // fail beyond mean + 6 sd (P < 1e-6 for a correct sampler).
    for (double mean : { 2.5, 9.5, 10.5, 40.0 }) {
        const int n = 400000;
        std::vector<double> counts(400, 0.0);
        Rng rng(hash_ids(7, static_cast<uint64_t>(mean * 10)), Stage::photons);
        for (int i = 0; i < n; ++i) {
            const uint64_t k = sample_poisson(mean, rng);
            if (k < counts.size())
                counts[k] += 1;
        }
        double chi2 = 0;
        int cells   = 0;
        for (size_t k = 0; k < counts.size(); ++k) {
            const double pk = std::exp(k * std::log(mean) - mean - std::lgamma(k + 1.0));
            const double expected = n * pk;
            if (expected < 20)
                continue;
            chi2 += (counts[k] - expected) * (counts[k] - expected) / expected;
            ++cells;
        }
        EXPECT_LT(chi2, (cells - 1) + 6 * std::sqrt(2.0 * (cells - 1))) << "mean " << mean;
    }
}

TEST(Sampling, PoissonEdgeCases)
{
    Rng rng(1, Stage::photons);
    EXPECT_EQ(sample_poisson(0.0, rng), 0u);
    EXPECT_EQ(sample_poisson(-1.0, rng), 0u);
    EXPECT_EQ(sample_poisson(NAN, rng), 0u);
}

TEST(Sampling, PoissonTableInvertsTheCdf)
{
    // Inversion is deterministic: on a grid of M uniforms (j + 0.5) / M,
    // each count k must come out for the grid points inside
    // [P(N < k), P(N <= k)), M p_k of them up to one at either end. p_k
    // from lgamma, independently of the table's recurrence.
    constexpr int M = 1 << 20;
    for (double mean : { 0.0, 0.3, 4.0, 16.0, 16.37, 250.0, 9000.0 }) {
        const PoissonTable table(mean);
        std::vector<int> hits;
        for (int j = 0; j < M; ++j) {
            const uint64_t k = table.sample((j + 0.5) / M);
            if (k >= hits.size())
                hits.resize(k + 1, 0);
            ++hits[k];
        }
        for (size_t k = 0; k < hits.size() + 5; ++k) {
            const double pk = mean > 0.0 ? std::exp(k * std::log(mean) - mean - std::lgamma(k + 1.0))
                                         : (k == 0 ? 1.0 : 0.0);
            const int got = k < hits.size() ? hits[k] : 0;
            EXPECT_NEAR(got, M * pk, 2.0 + 1e-9 * M) << "mean " << mean << ", k " << k;
        }
    }
    // The edges of the unit interval.
    const PoissonTable table(16.0);
    EXPECT_EQ(table.sample(0.0), 0u);
    EXPECT_GT(table.sample(1.0 - 0x1.0p-53), 40u);
    EXPECT_THROW(PoissonTable(-1.0), std::invalid_argument);
    EXPECT_THROW(PoissonTable(2e4), std::invalid_argument);
}

TEST(Rng, StreamsDependOnIdentityAndStage)
{
    Rng a(5, Stage::photons), b(5, Stage::photons), c(6, Stage::photons), d(5, Stage::kinetics);
    const double ua = a.uniform();
    EXPECT_EQ(ua, b.uniform());
    EXPECT_NE(ua, c.uniform());
    EXPECT_NE(ua, d.uniform());
    for (int i = 0; i < 1000; ++i) {
        const double u = a.uniform();
        EXPECT_GE(u, 0.0);
        EXPECT_LT(u, 1.0);
        const double v = a.uniform_open0();
        EXPECT_GT(v, 0.0);
        EXPECT_LE(v, 1.0);
    }
}

}  // namespace
}  // namespace filmgrain
