// Tests of regrain (filmgrain/regrain.h) on synthetic expected curves:
// the sensitivity matrix's inverse, a pixel at the curve's mean density
// given back unchanged, the linearised gain of a departure from it, and
// the stocks and pixels it refuses or passes through.
#include "filmgrain/regrain.h"

#include <gtest/gtest.h>

#include <cmath>

namespace filmgrain {
namespace {

/// A curve of D(v) = base + gamma log10(1 + v / 0.18) on the points an
/// expected curve has (v = 0, then 16 per octave from 2^-16 to 2^12 grey).
ExpectedCurve synthetic_curve(double gamma, double base = 0.2)
{
    ExpectedCurve c;
    c.base_density = base;
    c.max_density  = 6.0;
    const auto point = [&](double v) {
        CurvePoint p;
        p.value         = v;
        p.density       = base + gamma * std::log10(1.0 + v / 0.18);
        p.transmittance = std::pow(10.0, -(p.density - base));
        return p;
    };
    c.points.push_back(point(0.0));
    for (int k = -16 * 16; k <= 12 * 16; ++k)
        c.points.push_back(point(0.18 * std::exp2(k / 16.0)));
    return c;
}

std::vector<ExpectedCurve> synthetic_curves(size_t n, double gamma = 0.6)
{
    return std::vector<ExpectedCurve>(n, synthetic_curve(gamma));
}

Stock three_layer_stock(const std::array<std::array<double, 3>, 3>& rows)
{
    Stock stock;
    EXPECT_TRUE(load_stock("color-negative", stock));
    for (size_t l = 0; l < 3; ++l)
        stock.layers[l].sensitivity = rows[l];
    return stock;
}

/// The preset `name` (checked to have `layers` layers) and its regrain
/// model on synthetic curves.
void load_with_model(const std::string& name, size_t layers, Stock& stock, RegrainModel& m)
{
    ASSERT_TRUE(load_stock(name, stock));
    ASSERT_EQ(stock.layers.size(), layers);
    ASSERT_TRUE(make_regrain_model(stock, synthetic_curves(layers), m));
}

TEST(Regrain, ThreeLayersInvertTheSensitivityMatrix)
{
    Stock stock;
    RegrainModel m;
    ASSERT_NO_FATAL_FAILURE(load_with_model("color-negative", 3, stock, m));
    // to_rgb M = I: entries of M are <= 1 and det 0.72, so the inverse's
    // products carry a few ulps of 1 (2.2e-16 each): 1e-14 is far above.
    for (size_t i = 0; i < 3; ++i)
        for (size_t j = 0; j < 3; ++j) {
            double p = 0.0;
            for (size_t k = 0; k < 3; ++k)
                p += m.to_rgb[i][k] * stock.layers[k].sensitivity[j];
            EXPECT_NEAR(p, i == j ? 1.0 : 0.0, 1e-14) << i << "," << j;
        }
}

TEST(Regrain, OneLayerRowsShareTheSumOfItsWeights)
{
    Stock stock;
    RegrainModel m;
    ASSERT_NO_FATAL_FAILURE(load_with_model("paper", 1, stock, m));
    const auto& s = stock.layers[0].sensitivity;
    for (const auto& row : m.to_rgb) {
        EXPECT_EQ(row[0], 1.0 / (s[0] + s[1] + s[2]));
        EXPECT_EQ(row[1], 0.0);
        EXPECT_EQ(row[2], 0.0);
    }
}

TEST(Regrain, TheMeanDensityGivesTheInputBackAndADepartureItsLinearGain)
{
    // Identity sensitivities (vision3-500t's): layer l reads channel l.
    const Stock stock = three_layer_stock({ { { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } } });
    RegrainModel m;
    ASSERT_TRUE(make_regrain_model(stock, synthetic_curves(3), m));
    const float in[3] = { 0.05f, 0.18f, 0.7f };
    float mean_d[3], out[3];
    for (size_t l = 0; l < 3; ++l)
        mean_d[l] = static_cast<float>(
            m.curves[l].density_at(in[l] * m.uniform_field_gain[l]));
    regrain_pixel(m, in, mean_d, out);
    // The densities are floats: D rounds by <= 2^-24 D (D < 1 here), which
    // moves v by v ln(10) dD / gamma, gamma >= 0.06: below 4e-6 v.
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(out[c], in[c], 4e-6 * in[c]) << c;

    // 0.01 denser in G: more light than the mean, so G rises, by the
    // linearised inverse dv = v (E[T] - T) / (E[T] gamma), and only G.
    float denser[3] = { mean_d[0], mean_d[1] + 0.01f, mean_d[2] };
    regrain_pixel(m, in, denser, out);
    const ExpectedCurve& g = m.curves[1];
    const double v      = in[1] * m.uniform_field_gain[1];
    const double t_mean = g.transmittance_at(v);
    const double t      = std::pow(10.0, -(static_cast<double>(denser[1]) - g.base_density));
    const double expect = in[1] + in[1] / (t_mean * g.gamma_at(v)) * (t_mean - t);
    EXPECT_GT(out[1], in[1]);
    EXPECT_NEAR(out[1], expect, 1e-6);
    EXPECT_NEAR(out[0], in[0], 4e-6 * in[0]);
    EXPECT_NEAR(out[2], in[2], 4e-6 * in[2]);
}

TEST(Regrain, RefusesWhatCannotBeInvertedAndPassesNonFinitePixels)
{
    Stock two;
    ASSERT_TRUE(load_stock("color-negative", two));
    two.layers.pop_back();
    RegrainModel m;
    Status s = make_regrain_model(two, synthetic_curves(2), m);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("has 2 layers"), std::string::npos) << s.message();

    const Stock singular = three_layer_stock({ { { 1, 0, 0 }, { 0, 1, 0 }, { 1, 1, 0 } } });
    s = make_regrain_model(singular, synthetic_curves(3), m);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("is singular"), std::string::npos) << s.message();

    Stock flat;
    ASSERT_TRUE(load_stock("paper", flat));
    s = make_regrain_model(flat, synthetic_curves(1, 0.0), m);
    ASSERT_FALSE(s);
    EXPECT_NE(s.message().find("flat expected curve"), std::string::npos) << s.message();

    const Stock stock = three_layer_stock({ { { 1, 0, 0 }, { 0, 1, 0 }, { 0, 0, 1 } } });
    ASSERT_TRUE(make_regrain_model(stock, synthetic_curves(3), m));
    const float nan_in[3] = { 0.18f, std::nanf(""), 0.18f };
    const float d[3]      = { 0.5f, 0.5f, 0.5f };
    float out[3];
    regrain_pixel(m, nan_in, d, out);
    EXPECT_EQ(out[0], nan_in[0]);
    EXPECT_TRUE(std::isnan(out[1]));
    const float in[3]    = { 0.18f, 0.18f, 0.18f };
    const float bad_d[3] = { 0.5f, INFINITY, 0.5f };
    regrain_pixel(m, in, bad_d, out);
    for (int c = 0; c < 3; ++c)
        EXPECT_EQ(out[c], in[c]);
}

}  // namespace
}  // namespace filmgrain
