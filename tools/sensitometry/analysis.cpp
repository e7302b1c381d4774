// Sensitometric numbers from measured curves.
#include "analysis.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace filmgrain::sensitometry {

LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y,
                 const std::vector<double>& se)
{
    double sw = 0, sx = 0, sy = 0;
    for (size_t i = 0; i < x.size(); ++i) {
        const double w = se.empty() ? 1.0 : 1.0 / (se[i] * se[i]);
        sw += w;
        sx += w * x[i];
        sy += w * y[i];
    }
    const double mx = sx / sw, my = sy / sw;
    double sxx = 0, sxy = 0;
    for (size_t i = 0; i < x.size(); ++i) {
        const double w = se.empty() ? 1.0 : 1.0 / (se[i] * se[i]);
        sxx += w * (x[i] - mx) * (x[i] - mx);
        sxy += w * (x[i] - mx) * (y[i] - my);
    }
    LineFit f;
    f.slope     = sxx > 0 ? sxy / sxx : 0.0;
    f.intercept = my - f.slope * mx;
    // With known se the weights are absolute; with none, scale by residuals.
    double scale = 1.0;
    if (se.empty() && x.size() > 2) {
        double rss = 0;
        for (size_t i = 0; i < x.size(); ++i) {
            const double r = y[i] - f.intercept - f.slope * x[i];
            rss += r * r;
        }
        scale = rss / static_cast<double>(x.size() - 2);
    }
    f.slope_se     = sxx > 0 ? std::sqrt(scale / sxx) : 0.0;
    f.intercept_se = std::sqrt(scale * (1.0 / sw + mx * mx / sxx));
    f.covariance   = -mx * scale / sxx;
    return f;
}

std::vector<double> local_slopes(const std::vector<double>& x, const std::vector<double>& y,
                                 const std::vector<double>& se, double half_window)
{
    std::vector<double> out(x.size(), 0.0);
    for (size_t i = 0; i < x.size(); ++i) {
        std::vector<double> xs, ys, ss;
        for (size_t j = 0; j < x.size(); ++j)
            if (std::fabs(x[j] - x[i]) <= half_window + 1e-9) {
                xs.push_back(x[j]);
                ys.push_back(y[j]);
                if (!se.empty())
                    ss.push_back(std::max(se[j], 1e-6));
            }
        if (xs.size() < 3) {
            std::vector<size_t> idx(x.size());
            std::iota(idx.begin(), idx.end(), 0);
            std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) {
                return std::fabs(x[a] - x[i]) < std::fabs(x[b] - x[i]);
            });
            xs.clear();
            ys.clear();
            ss.clear();
            for (size_t k = 0; k < std::min<size_t>(3, idx.size()); ++k) {
                xs.push_back(x[idx[k]]);
                ys.push_back(y[idx[k]]);
                if (!se.empty())
                    ss.push_back(std::max(se[idx[k]], 1e-6));
            }
        }
        out[i] = fit_line(xs, ys, ss).slope;
    }
    return out;
}

double first_crossing(const std::vector<double>& x, const std::vector<double>& y,
                      double y_target)
{
    for (size_t i = 0; i < y.size(); ++i)
        if (y[i] >= y_target) {
            if (i == 0)
                return x[0];
            const double f = (y_target - y[i - 1]) / (y[i] - y[i - 1]);
            return x[i - 1] + f * (x[i] - x[i - 1]);
        }
    return std::numeric_limits<double>::quiet_NaN();
}

double interpolate(const std::vector<double>& x, const std::vector<double>& y, double x0)
{
    if (x.empty())
        return std::numeric_limits<double>::quiet_NaN();
    if (x0 <= x.front())
        return y.front();
    for (size_t i = 1; i < x.size(); ++i)
        if (x0 <= x[i]) {
            const double f = (x0 - x[i - 1]) / (x[i] - x[i - 1]);
            return y[i - 1] + f * (y[i] - y[i - 1]);
        }
    return y.back();
}

double iso6_speed(double h_m_lxs) { return 0.8 / h_m_lxs; }

double iso5800_speed(double h_green_lxs, double h_slowest_lxs)
{
    return std::sqrt(2.0) / std::sqrt(h_green_lxs * h_slowest_lxs);
}

CurveMetrics analyse_curve(const LayerCurve& c)
{
    CurveMetrics m;
    m.base_fog_density = c.fog_density;
    if (c.density.size() < 3)
        return m;
    m.d_max         = *std::max_element(c.density.begin(), c.density.end());
    m.speed_log10_h = first_crossing(c.log10_h, c.density, c.fog_density + kIso6SpeedNetDensity);
    m.iso_speed     = iso6_speed(std::pow(10.0, m.speed_log10_h));
    // Gamma: the steepest 0.6 log H window.
    const std::vector<double> wide = local_slopes(c.log10_h, c.density, c.density_se, 0.3);
    size_t g = 0;
    for (size_t i = 0; i < wide.size(); ++i) {
        // Only windows that are whole (not cut by the ends of the strip).
        if (c.log10_h[i] - 0.3 < c.log10_h.front() - 1e-9 || c.log10_h[i] + 0.3 > c.log10_h.back() + 1e-9)
            continue;
        if (wide[i] > wide[g])
            g = i;
    }
    m.gamma                = wide[g];
    m.gamma_log10_h_centre = c.log10_h[g];
    {
        std::vector<double> xs, ys, ss;
        for (size_t j = 0; j < c.log10_h.size(); ++j)
            if (std::fabs(c.log10_h[j] - c.log10_h[g]) <= 0.3 + 1e-9) {
                xs.push_back(c.log10_h[j]);
                ys.push_back(c.density[j]);
                ss.push_back(std::max(c.density_se[j], 1e-6));
            }
        m.gamma_se = fit_line(xs, ys, ss).slope_se;
    }
    m.iso_delta_density    = interpolate(c.log10_h, c.density, m.speed_log10_h + 1.30)
                          - (c.fog_density + 0.10);
    m.iso_mean_gradient    = m.iso_delta_density / 1.30;
    m.slopes         = local_slopes(c.log10_h, c.density, c.density_se, 0.2);
    m.toe_slope      = m.slopes.front();
    m.shoulder_slope = m.slopes.back();
    const auto grow = [&](double lo_fraction, double hi_fraction, double& lo, double& hi) {
        size_t a = g, b = g;
        const auto ok = [&](size_t i) {
            return m.slopes[i] >= lo_fraction * m.gamma && m.slopes[i] <= hi_fraction * m.gamma;
        };
        if (!ok(g)) {
            lo = hi = c.log10_h[g];
            return;
        }
        while (a > 0 && ok(a - 1))
            --a;
        while (b + 1 < m.slopes.size() && ok(b + 1))
            ++b;
        lo = c.log10_h[a];
        hi = c.log10_h[b];
    };
    grow(0.8, 1.2, m.straight_log10_h_lo, m.straight_log10_h_hi);
    grow(0.3, std::numeric_limits<double>::infinity(), m.latitude_log10_h_lo,
         m.latitude_log10_h_hi);
    m.latitude_stops = (m.latitude_log10_h_hi - m.latitude_log10_h_lo) / std::log10(2.0);
    return m;
}

GammaTimeFit fit_gamma_vs_time(const std::vector<double>& t, const std::vector<double>& gamma,
                               const std::vector<double>& se)
{
    GammaTimeFit best;
    double best_rss = std::numeric_limits<double>::infinity();
    const auto eval = [&](double k, double& g_inf) {
        double num = 0, den = 0;
        for (size_t i = 0; i < t.size(); ++i) {
            const double w = se.empty() ? 1.0 : 1.0 / (se[i] * se[i]);
            const double f = -std::expm1(-k * t[i]);
            num += w * f * gamma[i];
            den += w * f * f;
        }
        g_inf = num / den;
        double rss = 0;
        for (size_t i = 0; i < t.size(); ++i) {
            const double w = se.empty() ? 1.0 : 1.0 / (se[i] * se[i]);
            const double r = gamma[i] + g_inf * std::expm1(-k * t[i]);
            rss += w * r * r;
        }
        return rss;
    };
    // Coarse grid over log k spanning the times, then golden-section.
    const double t_max = *std::max_element(t.begin(), t.end());
    const double t_min = *std::min_element(t.begin(), t.end());
    double lo = std::log(0.01 / t_max), hi = std::log(100.0 / t_min), step = (hi - lo) / 400;
    double best_lk = lo;
    for (double lk = lo; lk <= hi; lk += step) {
        double g;
        const double rss = eval(std::exp(lk), g);
        if (rss < best_rss) {
            best_rss = rss;
            best_lk  = lk;
        }
    }
    double a = best_lk - step, b = best_lk + step;
    for (int it = 0; it < 60; ++it) {
        const double m1 = a + 0.382 * (b - a), m2 = a + 0.618 * (b - a);
        double g1, g2;
        if (eval(std::exp(m1), g1) < eval(std::exp(m2), g2))
            b = m2;
        else
            a = m1;
    }
    best.k_per_s = std::exp(0.5 * (a + b));
    double g;
    eval(best.k_per_s, g);
    best.gamma_inf = g;
    double rss = 0;
    for (size_t i = 0; i < t.size(); ++i) {
        const double r = gamma[i] + g * std::expm1(-best.k_per_s * t[i]);
        rss += r * r;
    }
    best.rms_residual = std::sqrt(rss / t.size());
    return best;
}

}  // namespace filmgrain::sensitometry
