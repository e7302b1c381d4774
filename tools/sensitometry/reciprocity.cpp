// Reciprocity: exposure for a fixed density as a function of time.
#include "reciprocity.h"

#include <algorithm>
#include <cmath>

#include "util/bracket.h"

namespace filmgrain::sensitometry {

Status exposure_for_net_density(const Stock& stock, double shutter_s, double net_density,
                                const std::vector<double>& fog_density, double guess_log10_h,
                                const PatchBudget& budget, const MeasureSettings& settings,
                                uint64_t seed, ReciprocityPoint& out)
{
    out           = ReciprocityPoint {};
    out.shutter_s = shutter_s;
    uint64_t index = 0;
    const auto measure = [&](double log10_h, double& net, double& se) -> Status {
        const PatchSpec p = plan_patch(stock, std::pow(10.0, log10_h), shutter_s, budget,
                                       patch_seed(seed, index++));
        PatchReading r;
        if (Status s = expose_patch(stock, p, settings, r); !s)
            return s;
        net = 0.0;
        double var = 0.0;
        for (size_t l = 0; l < r.layers.size(); ++l) {
            net += r.layers[l].density - fog_density[l];
            var += r.layers[l].density_se * r.layers[l].density_se;
        }
        net /= static_cast<double>(r.layers.size());
        se = std::sqrt(var) / static_cast<double>(r.layers.size());
        out.seconds += r.seconds;
        ++out.patches;
        out.patch_log10_h.push_back(log10_h);
        out.patch_net_density.push_back(net);
        out.patch_net_density_se.push_back(se);
        return {};
    };
    constexpr double kStep = 0.3;
    double x = guess_log10_h, y, s;
    if (Status st = measure(x, y, s); !st)
        return st;
    Bracket br;
    const auto value = [&](double at, double& value_out) {
        double unused_se;
        return measure(at, value_out, unused_se);
    };
    if (Status st = bracket_crossing(value, x, y, net_density, kStep, 40, br); !st)
        return st;
    if (!br.found)
        return Status::errorf("net density ", net_density, " not reached at shutter ",
                              shutter_s, " s between log10 H = ", guess_log10_h, " and ", br.x);
    const double x_lo = br.lo, x_hi = br.hi;
    for (double f : { 1.0 / 3.0, 2.0 / 3.0 }) {
        double yy, ss;
        if (Status st = measure(x_lo + f * (x_hi - x_lo), yy, ss); !st)
            return st;
    }
    const auto solve = [&](const std::vector<size_t>& idx, double& root, double& root_se) {
        std::vector<double> xs, ys, ses;
        for (size_t i : idx) {
            xs.push_back(out.patch_log10_h[i]);
            ys.push_back(out.patch_net_density[i]);
            ses.push_back(std::max(out.patch_net_density_se[i], 1e-6));
        }
        const LineFit f = fit_line(xs, ys, ses);
        root            = (net_density - f.intercept) / f.slope;
        // Delta method on root = (y - b) / m: the variance of the line at
        // the root divided by the slope squared.
        const double var_line = f.intercept_se * f.intercept_se + root * root * f.slope_se * f.slope_se
                                + 2.0 * root * f.covariance;
        root_se = std::sqrt(std::max(0.0, var_line)) / std::fabs(f.slope);
    };
    std::vector<size_t> inside;
    for (size_t i = 0; i < out.patch_log10_h.size(); ++i)
        if (out.patch_log10_h[i] >= x_lo - 1e-9 && out.patch_log10_h[i] <= x_hi + 1e-9)
            inside.push_back(i);
    double root, root_se;
    solve(inside, root, root_se);
    root = std::clamp(root, x_lo, x_hi);
    double yy, ss;
    if (Status st = measure(root, yy, ss); !st)
        return st;
    std::vector<size_t> order(out.patch_log10_h.size());
    for (size_t i = 0; i < order.size(); ++i)
        order[i] = i;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        return std::fabs(out.patch_log10_h[a] - root) < std::fabs(out.patch_log10_h[b] - root);
    });
    order.resize(3);
    solve(order, out.log10_h, out.log10_h_se);
    return {};
}

SchwarzschildFit fit_schwarzschild(const std::vector<ReciprocityPoint>& points, double t_min_s)
{
    std::vector<double> x, y, se;
    for (const auto& p : points)
        if (p.shutter_s >= t_min_s) {
            x.push_back(std::log10(p.shutter_s));
            y.push_back(p.log10_h);
            se.push_back(std::max(p.log10_h_se, 1e-4));
        }
    SchwarzschildFit f;
    f.points = static_cast<int>(x.size());
    if (x.size() < 2)
        return f;
    const LineFit line = fit_line(x, y, se);
    f.p         = 1.0 - line.slope;
    f.p_se      = line.slope_se;
    f.intercept = line.intercept;
    return f;
}

}  // namespace filmgrain::sensitometry
