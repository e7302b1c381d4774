// Regrain (filmgrain/regrain.h): each layer's expected curve inverted,
// linearised at the pixel, and the layers' grain carried back to R, G, B.
#include "filmgrain/regrain.h"

#include <Imath/ImathMatrix.h>

#include <algorithm>
#include <cmath>

namespace filmgrain {

double layer_value(const std::array<double, 3>& s, const float* rgb)
{
    if (!std::isfinite(rgb[0]) || !std::isfinite(rgb[1]) || !std::isfinite(rgb[2]))
        return 0.0;
    const double v = s[0] * rgb[0] + s[1] * rgb[1] + s[2] * rgb[2];
    return v > 0.0 ? v : 0.0;
}

Status make_regrain_model(const Stock& stock, std::vector<ExpectedCurve> curves,
                          RegrainModel& out)
{
    const size_t nl = stock.layers.size();
    if (nl != 1 && nl != 3)
        return Status::errorf("output=regrain maps layer exposures back to RGB, which needs a "
                              "one- or three-layer stock; '", stock.name, "' has ", nl,
                              " layers");
    if (curves.size() != nl)
        return Status::errorf("internal: ", curves.size(), " expected curves for ", nl,
                              " layers");
    RegrainModel m;
    for (size_t l = 0; l < nl; ++l) {
        m.sensitivity.push_back(stock.layers[l].sensitivity);
        m.uniform_field_gain.push_back(stock.layers[l].uniform_field_gain());
        // The steepest gamma, between points (where the slope is defined).
        double g_max = 0.0;
        const ExpectedCurve& c = curves[l];
        for (size_t i = 1; i + 1 < c.points.size(); ++i)
            g_max = std::max(g_max, c.gamma_at(std::sqrt(c.points[i].value * c.points[i + 1].value)));
        if (!(g_max > 0.0))
            return Status::errorf("output=regrain: layer '", stock.layers[l].name,
                                  "' has a flat expected curve (no gamma): its density says "
                                  "nothing about its exposure");
        m.min_gamma.push_back(kRegrainMinGammaFraction * g_max);
    }
    if (nl == 1) {
        const auto& s   = m.sensitivity[0];
        const double sum = s[0] + s[1] + s[2];
        for (auto& row : m.to_rgb)
            row = { 1.0 / sum, 0.0, 0.0 };
    } else {
        // M^-1: rows of M are the layers' sensitivities. The relative
        // determinant test names a singular stock; Imath inverts.
        const auto& a = m.sensitivity;
        const Imath::M33d mat(a[0][0], a[0][1], a[0][2], a[1][0], a[1][1], a[1][2], a[2][0],
                              a[2][1], a[2][2]);
        const double det = mat.determinant();
        double norm = 0.0;
        for (const auto& row : a)
            for (double v : row)
                norm = std::max(norm, std::fabs(v));
        if (!(std::fabs(det) > 1e-9 * norm * norm * norm))
            return Status::errorf("output=regrain: the layers' sensitivity matrix of '",
                                  stock.name, "' is singular (determinant ", det,
                                  "): layer exposures do not determine RGB");
        const Imath::M33d inv = mat.inverse();
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j)
                m.to_rgb[static_cast<size_t>(i)][static_cast<size_t>(j)] = inv[i][j];
    }
    m.curves = std::move(curves);
    out      = std::move(m);
    return {};
}

void regrain_pixel(const RegrainModel& m, const float* rgb_in, const float* density,
                   float* rgb_out)
{
    const float in[3] = { rgb_in[0], rgb_in[1], rgb_in[2] };
    std::copy_n(in, 3, rgb_out);
    if (!std::isfinite(in[0]) || !std::isfinite(in[1]) || !std::isfinite(in[2]))
        return;
    const size_t nl = m.curves.size();
    double dv[3]    = { 0.0, 0.0, 0.0 };
    for (size_t l = 0; l < nl; ++l) {
        if (!std::isfinite(density[l]))
            return;
        const ExpectedCurve& c = m.curves[l];
        const double v         = layer_value(m.sensitivity[l], in);
        if (!(v > 0.0))
            continue;  // no light: no grain to map (the fog's is not exposure)
        const double v_film = v * m.uniform_field_gain[l];
        const double t_mean = c.transmittance_at(v_film);
        const double t      = std::pow(10.0, -(static_cast<double>(density[l]) - c.base_density));
        const double gamma  = std::max(c.gamma_at(v_film), m.min_gamma[l]);
        // dv = -(T - E[T]) / (dE[T]/dv), dE[T]/dv = -E[T] gamma / v (gamma
        // is a log-log slope: the same for v and v_film).
        dv[l] = v / (t_mean * gamma) * (t_mean - t);
    }
    for (int c = 0; c < 3; ++c) {
        double d = 0.0;
        for (size_t l = 0; l < nl; ++l)
            d += m.to_rgb[static_cast<size_t>(c)][l] * dv[l];
        rgb_out[c] = static_cast<float>(in[c] + d);
    }
}

}  // namespace filmgrain
