// MODEL.md section 10: development inhibitors.
#include "model/inhibition.h"

#include "model/dye.h"

#include <algorithm>
#include <atomic>
#include <utility>

#include "model/image_formation.h"
#include "model/light_spread.h"
#include "util/parallel.h"

namespace filmgrain {

Status plan_inhibition(const Stock& stock, const SceneSettings& scene,
                       const std::vector<const LayerExposure*>& exposures, int64_t frame_width,
                       int64_t frame_height, double pitch_um, int nthreads, InhibitionPlan& out,
                       const std::atomic<bool>* cancel, SpreadMethod method)
{
    const auto cancelled = [cancel] { return cancel_requested(cancel); };
    out = InhibitionPlan {};
    const size_t nl = stock.layers.size();
    out.log_factor.assign(nl, nullptr);
    out.max_log_factor.assign(nl, 0.0);
    if (!stock.inhibits())
        return {};
    // Dbar_j comes from the curves without inhibition (MODEL.md 10: "the
    // expected density that layer j would have at x without inhibition").
    Stock plain      = stock;
    plain.inhibition = {};
    ExpectedCurveOptions options;
    options.nthreads = nthreads;
    options.cancel   = cancel;
    std::vector<ExpectedCurve> curves;
    if (Status s = expected_curves(plain, scene, options, curves); !s)
        return cancelled() ? Status::error("render cancelled") : Status::errorf("inhibition (MODEL.md 10) needs each layer's expected curve: ",
                              s.message());

    // The donors: every layer some row names.
    std::vector<bool> donor(nl, false);
    for (size_t k = 0; k < nl; ++k)
        for (size_t j = 0; j < nl; ++j)
            donor[j] = donor[j] || stock.inhibition[k][j] != 0.0;
    const size_t n = static_cast<size_t>(frame_width * frame_height);
    std::vector<std::vector<double>> blurred(nl);
    std::atomic<bool> stop { false };
    // Each donor's density above the fog, row by row on every thread. Beyond
    // the frame (gate) the film is unexposed: its density is the fog's. The
    // blur acts on the density above the fog (0 outside the frame, as
    // spread_frame takes it with gate; with clamp it continues the edge's),
    // the fog added back after.
    std::vector<double> fog(nl, 0.0);
    for (size_t j = 0; j < nl; ++j) {
        if (!donor[j])
            continue;
        fog[j] = curves[j].min_density() - curves[j].base_density;
        const ExpectedCurveReader curve(curves[j]);
        std::vector<double>& d = blurred[j];
        d.resize(n);
        parallel_for(frame_height, nthreads, stop, [&](int, int64_t y) {
            if (cancelled())
                throw Stopped {};
            double* row = d.data() + y * frame_width;
            for (int64_t x = 0; x < frame_width; ++x)
                row[x] = curve.density_at(exposures[j]->value(x, y)) - curves[j].base_density
                         - fog[j];
        });
    }
    // The blur, one donor per worker (a transform takes ~0.5 s at 4K).
    parallel_for(static_cast<int64_t>(nl), nthreads, stop, [&](int, int64_t jj) {
        const size_t j = static_cast<size_t>(jj);
        if (!donor[j] || cancelled())
            return;
        std::vector<double>& d = blurred[j];
        if (stock.inhibitor_diffusion_um > 0.0)
            d = spread_frame(std::move(d), frame_width, frame_height, pitch_um, 1.0,
                             stock.inhibitor_diffusion_um, HalationSpec(), scene.edge, method);
        for (double& v : d)
            v += fog[j];
    });

    if (cancelled())
        return Status::error("render cancelled");
    for (size_t k = 0; k < nl; ++k) {
        double error = 0.0;
        bool any     = false;
        for (size_t j = 0; j < nl; ++j) {
            any = any || stock.inhibition[k][j] != 0.0;
            error += stock.inhibition[k][j] * curves[j].density_error;
        }
        if (!any)
            continue;
        out.error = std::max(out.error, error);
        for (size_t j = 0; j < nl; ++j) {
            double largest = 0.0;
            for (const CurvePoint& p : curves[j].points)
                largest = std::max(largest, p.density - curves[j].base_density);
            out.max_log_factor[k] += stock.inhibition[k][j] * largest;
        }
        auto plane      = std::make_shared<FramePlane>();
        plane->width    = frame_width;
        plane->height   = frame_height;
        plane->pitch_um = pitch_um;
        plane->clamp_edge = scene.edge == FrameEdge::clamp;
        plane->values.resize(n);
        parallel_for(frame_height, nthreads, stop, [&](int, int64_t y) {
            for (size_t i = static_cast<size_t>(y * frame_width);
                 i < static_cast<size_t>((y + 1) * frame_width); ++i) {
                double l = 0.0;
                for (size_t j = 0; j < nl; ++j)
                    if (stock.inhibition[k][j] != 0.0)
                        l += stock.inhibition[k][j] * blurred[j][i];
                plane->values[i] = static_cast<float>(std::max(0.0, l));
            }
        });
        out.log_factor[k] = std::move(plane);
    }
    return {};
}

double neutral_log_factor(const Stock& stock, const std::vector<ExpectedCurve>& plain, size_t k,
                          double value)
{
    if (!stock.inhibits())
        return 0.0;
    // The neutral grey y that gives layer k the value v: every layer j
    // then has y * w_j.
    const double grey = value / stock.layers[k].neutral_weight();
    double log_factor = 0.0;
    for (size_t j = 0; j < plain.size(); ++j)
        if (stock.inhibition[k][j] != 0.0)
            log_factor += stock.inhibition[k][j]
                          * (plain[j].density_at(grey * stock.layers[j].neutral_weight())
                             - plain[j].base_density);
    return log_factor;
}

void apply_inhibition(const Stock& stock, std::vector<ExpectedCurve>& curves)
{
    if (!stock.inhibits())
        return;
    const std::vector<ExpectedCurve> plain = curves;
    for (size_t k = 0; k < curves.size(); ++k) {
        double error = 0.0;
        for (size_t j = 0; j < curves.size(); ++j)
            error += stock.inhibition[k][j] * plain[j].density_error;
        double largest_density = 0.0;
        for (CurvePoint& p : curves[k].points) {
            const double log_factor = neutral_log_factor(stock, plain, k, p.value);
            if (p.covers.empty()) {
                // E[T] = exp(-K) and P -> P exp(-log_factor) scale K alike.
                p.transmittance = std::pow(p.transmittance, std::exp(-log_factor));
            } else {
                // Coupler-limited populations (docs/model.md): every
                // population's cover scales, E[T] is recomputed from them.
                std::vector<double> thinned = p.covers;
                for (double& c : thinned)
                    c *= std::exp(-log_factor);
                p.transmittance = layer_mean_transmittance(stock.layers[k], thinned);
            }
            p.density       = density_from_transmittance(p.transmittance, curves[k].max_density,
                                                     curves[k].base_density);
            largest_density = std::max(largest_density, p.density - curves[k].base_density);
        }
        // D_k - base = log10(e) K exp(-log_factor): an error e in
        // log_factor moves it by at most (D_k - base) e. (A coupler-limited
        // population's -ln E[T_p] is concave in its cover and 0 at 0, so
        // its change is at most e times itself too.)
        curves[k].density_error += largest_density * error;
    }
}

}  // namespace filmgrain
