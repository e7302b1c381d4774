// One step of a virtual test strip: render, then read like a densitometer.
#include "patch.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "model/light_spread.h"

namespace filmgrain::sensitometry {

double patch_margin_um(const Stock& stock, double pitch_um)
{
    double r_um = 0.0;
    for (const Layer& layer : stock.layers)
        for (const Population& pop : layer.populations) {
            const double s = pop.diameter_log_sigma;
            r_um = std::max(r_um, 0.5 * pop.diameter_um * std::exp(-0.5 * s * s + 6.0 * s));
        }
    return r_um + patch_spread_reach_um(stock) + pitch_um;
}

double patch_spread_reach_um(const Stock& stock)
{
    // The kernels' truncation (core/src/model/light_spread.h: 6 sigma; the base
    // kernel's reach, where kBaseHalationTail of its light is cut) and
    // radius; inhibition blurs densities made from the spread exposure.
    double spread_um = 0.0;
    for (const Layer& layer : stock.layers)
        spread_um = std::max(spread_um, (layer.scatters() ? 6.0 * layer.scatter_sigma_um : 0.0)
                                            + layer_halation(stock, layer).reach_um());
    return spread_um + (stock.inhibits() ? 6.0 * stock.inhibitor_diffusion_um : 0.0);
}

double density_from_mean_transmittance(double mean_transmittance, double base_density)
{
    return -std::log10(mean_transmittance) + base_density;
}

Status expose_patch(const Stock& stock, const PatchSpec& spec, const MeasureSettings& settings,
                    PatchReading& out, std::vector<std::vector<double>>* transmittance)
{
    if (!(spec.exposure_lxs >= 0.0 && spec.exposure_lxs <= 1e12))
        return Status::errorf("patch exposure = ", spec.exposure_lxs,
                              " lx.s: must be in [0, 1e12]");
    if (!(spec.side_um > 0.0) || !(spec.pitch_um > 0.0) || spec.pitch_um > spec.side_um)
        return Status::errorf("patch side = ", spec.side_um, " um, pitch = ", spec.pitch_um,
                              " um: need 0 < pitch <= side");
    if (spec.blocks < 2 || spec.blocks > 64)
        return Status::errorf("patch blocks = ", spec.blocks, ": must be in [2, 64]");
    const int64_t side_px
        = std::max<int64_t>(spec.blocks, std::llround(spec.side_um / spec.pitch_um));
    const double pitch_um = spec.pitch_um;

    // A grey input over the whole frame: every grain whose disc lies in
    // the frame sees the same exposure. Grey y = 0.18 at an exposure
    // offset of log2(H / exposure_at_grey) gives H exactly (MODEL.md 2:
    // H = v / 0.18 * exposure_at_grey_lxs * 2^stops). One input pixel,
    // unless the stock spreads light or inhibits development (MODEL.md 9,
    // 10): those act on the input's pixels with nothing beyond the frame,
    // so the input has the scan's pixels (at most kMaxPatchInputPx a side:
    // the base kernel reaches 8 to 10 mm, 4000 to 5000 pixels of 2 um;
    // coarser input pixels see the same uniform field) and the margin the
    // kernels' reach plus an input pixel, and the square's pixels see a
    // uniform field's values.
    const float grey = spec.exposure_lxs > 0.0 ? 0.18f : 0.0f;
    const bool spreads = patch_spread_reach_um(stock) > 0.0;
    int64_t margin_px = 0, scan_px = 0, input_px = 1;
    for (double input_pitch_um = pitch_um;;) {
        margin_px = static_cast<int64_t>(
            std::ceil(patch_margin_um(stock, input_pitch_um) / pitch_um));
        scan_px   = side_px + 2 * margin_px;
        if (!spreads)
            break;
        input_px = std::min(scan_px, kMaxPatchInputPx);
        // The input pitch grows with the scan it covers: until the margin
        // holds the pitch it was computed with (two rounds at most).
        const double pitch
            = static_cast<double>(scan_px) * pitch_um / static_cast<double>(input_px);
        if (pitch <= input_pitch_um)
            break;
        input_pitch_um = pitch;
    }
    const std::vector<float> input_pixels(static_cast<size_t>(input_px * input_px), grey);
    SceneSettings scene;
    scene.exposure_stops = spec.exposure_lxs > 0.0
                               ? std::log2(spec.exposure_lxs / stock.exposure_at_grey_lxs)
                               : 0.0;
    scene.shutter_s      = spec.shutter_s;
    scene.width_mm = static_cast<double>(scan_px) * pitch_um / 1000.0;
    scene.seed           = spec.seed;
    const ImageView input { input_pixels.data(), input_px, input_px, 1 };
    RenderSettings rs;
    rs.engine     = settings.engine;
    if (settings.kinetics) {
        rs.kinetics        = settings.kinetics;
        rs.photons = ExposureMethod::disc;
        rs.coverage        = CoverageMethod::exact;
    }
    rs.nthreads   = settings.nthreads;
    rs.scan_width = scan_px;
    rs.scan_height = scan_px;
    rs.roi        = Roi { margin_px, margin_px, margin_px + side_px, margin_px + side_px };
    // Tiles so that every worker has about two (a small patch would be a
    // single default 64 px tile: one busy thread). The output does not
    // depend on the tile size.
    const int workers = settings.nthreads > 0
                            ? settings.nthreads
                            : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    const int64_t tiles_per_side = static_cast<int64_t>(std::ceil(std::sqrt(2.0 * workers)));
    rs.tile_size_px = static_cast<int>(std::clamp<int64_t>(
        (side_px + tiles_per_side - 1) / tiles_per_side, 16, 4096));
    const size_t nl = stock.layers.size();
    std::vector<float> density(static_cast<size_t>(side_px * side_px) * nl);
    RenderStats stats;
    const auto start = std::chrono::steady_clock::now();
    if (Status s = render_negative(stock, scene, input, rs, density.data(), &stats); !s)
        return s;
    out         = PatchReading {};
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    out.engine  = stats.engine.empty() ? name_of(settings.engine) : stats.engine;
    out.side_px = side_px;
    out.pitch_um = pitch_um;
    if (transmittance)
        transmittance->assign(nl, std::vector<double>(static_cast<size_t>(side_px * side_px)));

    const double exposure_lxs = static_cast<double>(grey) / 0.18 * stock.exposure_at_grey_lxs
                                * std::exp2(scene.exposure_stops);
    const int b          = spec.blocks;
    for (size_t l = 0; l < nl; ++l) {
        const double base    = stock.layer_base_density(l);
        const float clamp_at = static_cast<float>(stock.max_density + base);
        LayerReading r;
        r.name = stock.layers[l].name;
        double sens = 0.0;
        for (double w : stock.layers[l].sensitivity)
            sens += w;
        r.exposure_lxs = exposure_lxs * sens;
        // Sums per block in a fixed order (deterministic).
        std::vector<double> block_sum(static_cast<size_t>(b * b), 0.0);
        std::vector<double> block_n(static_cast<size_t>(b * b), 0.0);
        for (int64_t y = 0; y < side_px; ++y)
            for (int64_t x = 0; x < side_px; ++x) {
                const size_t i = static_cast<size_t>(y * side_px + x);
                const float d  = density[i * nl + l];
                const double t = std::pow(10.0, -(static_cast<double>(d) - base));
                if (d >= clamp_at)
                    ++r.clamped_pixels;
                if (transmittance)
                    (*transmittance)[l][i] = t;
                const size_t k = static_cast<size_t>((y * b / side_px) * b + x * b / side_px);
                block_sum[k] += t;
                block_n[k] += 1.0;
            }
        double sum = 0.0, n = 0.0;
        for (size_t k = 0; k < block_sum.size(); ++k) {
            sum += block_sum[k];
            n += block_n[k];
        }
        const double mean = sum / n;
        // Batch means: blocks are equal within a pixel; weight by pixels.
        double var = 0.0;
        for (size_t k = 0; k < block_sum.size(); ++k) {
            const double m = block_sum[k] / block_n[k];
            var += block_n[k] / n * (m - mean) * (m - mean);
        }
        const double blocks_n = static_cast<double>(block_sum.size());
        const double se_t     = std::sqrt(var / (blocks_n - 1.0));
        r.mean_transmittance  = mean;
        r.density             = density_from_mean_transmittance(mean, base);
        r.density_se          = se_t / (mean * std::log(10.0));
        r.clamp_density_bound = static_cast<double>(r.clamped_pixels)
                                * std::pow(10.0, -stock.max_density) / (n * mean * std::log(10.0));
        if (l < stats.layers.size()) {
            r.grains           = stats.layers[l].grains;
            r.developed        = stats.layers[l].developed;
            r.absorbed_photons = stats.layers[l].absorbed_photons;
        }
        out.layers.push_back(r);
    }
    return {};
}

}  // namespace filmgrain::sensitometry
