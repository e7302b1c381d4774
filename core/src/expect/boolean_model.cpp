// What the model predicts for a uniform layer: development by grain size,
// the Boolean model of opaque discs, aperture variance, Nutting and
// Siedentopf. No rendering: the distributions of MODEL.md 1-5 composed.
#include "expect/boolean_model.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "model/development.h"
#include "expect/expectations.h"
#include "model/exposure.h"
#include "expect/grain_counts.h"
#include "model/kinetics.h"
#include "kernels/pixel_model.h"
#include "util/bracket.h"

namespace filmgrain {

Status develop_by_size(const Stock& stock, const Population& pop, double exposure_lxs,
                       double shutter_s, int max_samples, uint64_t seed,
                       PopulationDevelopment& out, int min_samples)
{
    if (pop.rate_area_exponent != 0.0)
        return Status::errorf("rate_area_exponent = ", pop.rate_area_exponent,
                              ": the size-resolved prediction needs 0 (P(develop | N) "
                              "independent of the grain size)");
    const double photons_per_um2 = pop.quantum_efficiency * kPhotonsPerUm2PerLxs * exposure_lxs;
    out = PopulationDevelopment {};
    out.grains_per_um2 = pop.grains_per_um2;
    // The size nodes and photon counts of grain_counts.h: one quadrature
    // for every "sizes x counts x P(develop | N)" integral.
    const std::vector<SizeNode>& sizes = size_quadrature(pop);
    for (const SizeNode& q : sizes) {
        DevelopedSize node;
        node.diameter_um = diameter_at_z_um(pop, q.z);
        node.weight      = q.weight;
        out.nodes.push_back(node);
    }
    const auto for_each_term = [&](auto&& f) { for_each_size_and_count(pop, photons_per_um2, f); };

    // Importance of each photon count N: its share of E[a P] and of
    // E[a^2 P] (what the mean and the variance integrals weigh).
    std::map<uint64_t, std::array<double, 2>> importance;
    for_each_term([&](size_t, double w, double a, uint64_t n, double p) {
        auto& imp = importance[n];
        imp[0] += w * a * p;
        imp[1] += w * a * a * p;
    });
    double total[2] = { 0.0, 0.0 };
    for (const DevelopedSize& node : out.nodes) {
        const double a = M_PI / 4.0 * node.diameter_um * node.diameter_um;
        total[0] += node.weight * a;
        total[1] += node.weight * a * a;
    }
    // Drop the lightest counts while their share of both stays below 1e-7;
    // a dropped count borrows P(develop | N) from the nearest kept one
    // (P is bounded, so the error is below that share).
    std::vector<std::pair<double, uint64_t>> by_share;
    for (const auto& [n, imp] : importance)
        by_share.emplace_back(std::max(imp[0] / total[0], imp[1] / total[1]), n);
    std::sort(by_share.begin(), by_share.end());
    double dropped = 0.0;
    size_t first_kept = 0;
    while (first_kept < by_share.size() && dropped + by_share[first_kept].first < 1e-7)
        dropped += by_share[first_kept++].first;
    const double share_max = by_share.empty() ? 1.0 : by_share.back().first;

    const Development dev(stock);
    DevelopGivenPhotons given_n({ pop.k_pair_per_s, pop.k_join_per_s, pop.k_loss_per_s },
                                shutter_s, dev, max_samples, seed);
    std::map<uint64_t, Estimate> p_given_n;
    for (size_t i = first_kept; i < by_share.size(); ++i) {
        // A count's Monte Carlo error is weighted by its share, so light
        // counts need few runs.
        const int runs = static_cast<int>(std::ceil(std::max<double>(
            min_samples, max_samples * by_share[i].first / share_max)));
        p_given_n[by_share[i].second] = given_n(by_share[i].second, runs);
    }
    const auto p_of = [&](uint64_t n) -> Estimate {
        auto it = p_given_n.lower_bound(n);
        if (it == p_given_n.end())
            return std::prev(it)->second;
        if (it->first == n || it == p_given_n.begin())
            return it->second;
        auto below = std::prev(it);
        return (n - below->first <= it->first - n) ? below->second : it->second;
    };

    double var_area = 0.0;
    std::map<uint64_t, double> area_weight;  // d E[aP] / d P(N), for the error
    std::vector<double> p_node(out.nodes.size(), 0.0);
    for_each_term([&](size_t k, double w, double a, uint64_t n, double p) {
        p_node[k] += p * p_of(n).value;
        area_weight[n] += w * a * p;
    });
    for (size_t k = 0; k < out.nodes.size(); ++k) {
        DevelopedSize& node = out.nodes[k];
        const double a = M_PI / 4.0 * node.diameter_um * node.diameter_um;
        node.develop_probability = std::clamp(p_node[k], 0.0, 1.0);
        out.develop_fraction += node.weight * node.develop_probability;
        out.area_developed_um2 += node.weight * a * node.develop_probability;
        out.area2_developed_um4 += node.weight * a * a * node.develop_probability;
    }
    for (const auto& [n, w] : area_weight) {
        const auto it = p_given_n.find(n);
        if (it != p_given_n.end())
            var_area += w * w * it->second.standard_error * it->second.standard_error;
    }
    out.area_developed_se_um2 = std::sqrt(var_area) + dropped * total[0];
    return {};
}

BooleanLayer::BooleanLayer(const std::vector<PopulationDevelopment>& populations,
                           const ImageOverlap& image, double h_step_um)
    : m_step_um(h_step_um)
{
    double h_max = 0.0;
    for (const auto& pop : populations) {
        m_developed_per_um2 += pop.grains_per_um2 * pop.develop_fraction;
        m_area_developed += pop.grains_per_um2 * pop.area_developed_um2;
        const bool limited = pop.filled.opacity > 0.0;
        double blocked = 0.0;
        for (const DevelopedSize& node : pop.nodes) {
            const double r_um = 0.5 * node.diameter_um;
            blocked += node.weight * node.develop_probability
                       * (limited ? image.cloud_lens_um2(r_um, 0.0) : image.blocking_um2(r_um));
            if (node.weight * node.develop_probability > 1e-15)
                h_max = std::max(h_max, image.overlap_range_um(r_um));
        }
        if (limited)
            m_filled.push_back({ pop.filled, pop.grains_per_um2 * blocked, {} });
        else
            m_blocking += pop.grains_per_um2 * blocked;
    }
    const size_t steps = static_cast<size_t>(std::ceil(h_max / m_step_um)) + 2;
    m_k.assign(steps, 0.0);
    // Per node, once: its radius, its weight n w P, how far it reaches and
    // which table it adds to (K, or its coupler-limited population's s).
    struct Term {
        double r_um, weight, range_um;
        std::vector<double>* table;
        bool limited;
    };
    std::vector<Term> terms;
    size_t f = 0;
    for (const auto& pop : populations) {
        const bool limited       = pop.filled.opacity > 0.0;
        std::vector<double>* tab = &m_k;
        if (limited) {
            tab = &m_filled[f++].k;
            tab->assign(steps, 0.0);
        }
        for (const DevelopedSize& node : pop.nodes) {
            const double w = pop.grains_per_um2 * node.weight * node.develop_probability;
            if (w > 0.0)
                terms.push_back({ 0.5 * node.diameter_um, w,
                                  image.overlap_range_um(0.5 * node.diameter_um), tab, limited });
        }
    }
    for (size_t i = 0; i < steps; ++i) {
        const double h = static_cast<double>(i) * m_step_um;
        double k = 0.0;
        for (const Term& t : terms) {
            if (!(t.range_um > h))
                continue;
            if (t.limited)
                (*t.table)[i] += t.weight * image.cloud_lens_um2(t.r_um, h);
            else
                k += t.weight * image.overlap_um2(t.r_um, h);
        }
        m_k[i] = k;
    }
    m_range_um = 0.0;
    for (size_t i = 0; i < steps; ++i) {
        bool reaches = m_k[i] > 1e-9 * m_k[0];
        for (const Filled& fi : m_filled)
            reaches = reaches || fi.k[i] > 1e-9 * fi.k[0];
        if (reaches)
            m_range_um = static_cast<double>(i + 1) * m_step_um;
    }
}

Status predict_layer(const Stock& stock, size_t layer, double exposure_lxs, double shutter_s,
                     int max_samples, uint64_t seed, BooleanLayer& out, int min_samples)
{
    if (layer >= stock.layers.size())
        return Status::errorf("layer ", layer, ": the stock has ", stock.layers.size());
    double sens = 0.0;
    for (double w : stock.layers[layer].sensitivity)
        sens += w;
    std::vector<PopulationDevelopment> pops;
    for (const Population& pop : stock.layers[layer].populations) {
        PopulationDevelopment d;
        if (Status s = develop_by_size(stock, pop, exposure_lxs * sens, shutter_s, max_samples,
                                       seed + pops.size(), d, min_samples);
            !s)
            return s;
        pops.push_back(std::move(d));
    }
    const ImageOverlap image(stock.layers[layer]);
    for (size_t p = 0; p < pops.size(); ++p)
        pops[p].filled = image.filled(stock.layers[layer].populations[p]);
    out = BooleanLayer(pops, image);
    return {};
}

BooleanLayer boolean_layer_at(const std::vector<PixelPopulation>& populations, double value,
                              const ImageOverlap& image, double develop_factor,
                              double h_step_um)
{
    std::vector<PopulationDevelopment> pops;
    for (const PixelPopulation& pp : populations) {
        PopulationDevelopment d;
        d.grains_per_um2 = pp.population->grains_per_um2;
        d.filled         = image.filled(*pp.population);
        for (const SizeNode& q : size_quadrature(*pp.population)) {
            const double r_um  = pp.grains->radius_at_z_um(q.z);
            const double a_um2 = M_PI * r_um * r_um;
            DevelopedSize node;
            node.diameter_um         = 2.0 * r_um;
            node.weight              = q.weight;
            node.develop_probability = develop_factor
                                       * pixel_develop_probability(
                                           pp, pp.photons_per_value_um2 * value * a_um2);
            d.develop_fraction += node.weight * node.develop_probability;
            d.area_developed_um2 += node.weight * a_um2 * node.develop_probability;
            d.area2_developed_um4 += node.weight * a_um2 * a_um2 * node.develop_probability;
            d.nodes.push_back(node);
        }
        pops.push_back(std::move(d));
    }
    return BooleanLayer(pops, image, h_step_um);
}

Status exposure_for_predicted_density(const Stock& stock, size_t layer, double net_density,
                                      double shutter_s, double log10_h_guess, double& log10_h)
{
    const auto density_at = [&](double x, double& d) -> Status {
        BooleanLayer b;
        if (Status s = predict_layer(stock, layer, std::pow(10.0, x), shutter_s, 50, 99, b, 2); !s)
            return s;
        d = b.net_density();
        return {};
    };
    double x = log10_h_guess, d = 0.0;
    if (Status s = density_at(x, d); !s)
        return s;
    Bracket br;
    if (Status s = bracket_crossing(density_at, x, d, net_density, 0.5, 12, br); !s)
        return s;
    if (!br.found)
        return Status::errorf("predicted net density ", net_density, " not reached within 6 "
                              "decades of log10 H = ", log10_h_guess, " (last: ", br.y, ")");
    double a = br.lo, b = br.hi;
    while (b - a > 0.002) {
        const double m = 0.5 * (a + b);
        double dm = 0.0;
        if (Status s = density_at(m, dm); !s)
            return s;
        (dm < net_density ? a : b) = m;
    }
    log10_h = 0.5 * (a + b);
    return {};
}

double BooleanLayer::mean_transmittance() const
{
    double t = std::exp(-coverage());
    for (const Filled& f : m_filled)
        t *= f.image.mean(f.cover);
    return t;
}

double BooleanLayer::net_density() const
{
    if (m_filled.empty())
        return coverage() / std::log(10.0);
    return -std::log10(mean_transmittance());
}


double BooleanLayer::mean_developed_area_um2() const
{
    return m_developed_per_um2 > 0.0 ? m_area_developed / m_developed_per_um2 : 0.0;
}

double BooleanLayer::overlap(double h_um) const
{
    const double x = std::fabs(h_um) / m_step_um;
    const size_t i = static_cast<size_t>(x);
    if (i + 1 >= m_k.size() || h_um >= m_range_um)
        return 0.0;
    const double f = x - static_cast<double>(i);
    return m_k[i] * (1.0 - f) + m_k[i + 1] * f;
}

double BooleanLayer::covariance(double h_um) const
{
    const double t = mean_transmittance();
    if (m_filled.empty())
        return t * t * std::expm1(overlap(h_um));
    double log_ratio = overlap(h_um);
    const double x   = std::fabs(h_um) / m_step_um;
    const size_t i   = static_cast<size_t>(x);
    if (i + 1 < m_k.size() && h_um < m_range_um) {
        const double w = x - static_cast<double>(i);
        for (const Filled& f : m_filled)
            log_ratio += f.image.log_pair_ratio(
                f.cover, std::expm1(f.k[i] * (1.0 - w) + f.k[i + 1] * w));
    }
    return t * t * std::expm1(log_ratio);
}

double ApertureTemplate::area_um2() const
{
    double sum = 0.0;
    for (double w : weights)
        sum += w;
    return sum * pitch_um * pitch_um;
}

ApertureTemplate make_circular_aperture(double diameter_um, double pitch_um)
{
    ApertureTemplate a;
    a.diameter_um = diameter_um;
    a.pitch_um    = pitch_um;
    const double r = 0.5 * diameter_um;
    a.radius_px    = static_cast<int>(std::ceil(r / pitch_um + 0.5));
    const int side = 2 * a.radius_px + 1;
    a.weights.assign(static_cast<size_t>(side * side), 0.0);
    for (int dy = -a.radius_px; dy <= a.radius_px; ++dy)
        for (int dx = -a.radius_px; dx <= a.radius_px; ++dx) {
            const double x0 = (dx - 0.5) * pitch_um, y0 = (dy - 0.5) * pitch_um;
            a.weights[static_cast<size_t>((dy + a.radius_px) * side + dx + a.radius_px)]
                = disc_rect_area_um2(0.0, 0.0, r, x0, y0, x0 + pitch_um, y0 + pitch_um)
                  / (pitch_um * pitch_um);
        }
    return a;
}

namespace {

/// Cpix(L) for |L_x|, |L_y| <= lag_max: the covariance of the mean
/// transmittances of two pixels of side p whose offset is L pixels,
/// (1/p^4) integral of C(h) (p - |h_x - L_x p|)(p - |h_y - L_y p|) over the
/// tent's support. Midpoint rule on a 32 x 32 grid (the tent is bilinear
/// and C is smooth away from h = 0, where it has only a cusp: the rule's
/// error is far below the statistical errors). Row-major, (2 lag_max + 1)^2.
std::vector<double> pixel_covariances(const BooleanLayer& layer, double p, int lag_max)
{
    constexpr int kGrid = 32;
    const int lag_side  = 2 * lag_max + 1;
    std::vector<double> cpix(static_cast<size_t>(lag_side * lag_side), 0.0);
    for (int ly = 0; ly <= lag_max; ++ly)
        for (int lx = ly; lx <= lag_max; ++lx) {
            double sum = 0.0;
            for (int j = 0; j < kGrid; ++j) {
                const double v  = -p + (j + 0.5) * 2.0 * p / kGrid;
                const double ty = p - std::fabs(v);
                for (int i = 0; i < kGrid; ++i) {
                    const double u  = -p + (i + 0.5) * 2.0 * p / kGrid;
                    const double tx = p - std::fabs(u);
                    sum += tx * ty * layer.covariance(std::hypot(lx * p + u, ly * p + v));
                }
            }
            const double c = sum * (2.0 * p / kGrid) * (2.0 * p / kGrid) / (p * p * p * p);
            // Symmetric in the signs of the lags and under swapping them.
            for (int sx : { -1, 1 })
                for (int sy : { -1, 1 }) {
                    cpix[static_cast<size_t>((sy * ly + lag_max) * lag_side + sx * lx + lag_max)] = c;
                    cpix[static_cast<size_t>((sx * lx + lag_max) * lag_side + sy * ly + lag_max)] = c;
                }
        }
    return cpix;
}

}  // namespace

double aperture_transmittance_variance(const BooleanLayer& layer,
                                       const ApertureTemplate& aperture)
{
    const double p    = aperture.pitch_um;
    const int lag_max = static_cast<int>(std::ceil(layer.range_um() / p)) + 1;
    const int lag_side = 2 * lag_max + 1;
    const std::vector<double> cpix = pixel_covariances(layer, p, lag_max);
    const int r    = aperture.radius_px;
    double w_total = 0.0;
    for (double w : aperture.weights)
        w_total += w;
    double var = 0.0;
    for (int ly = -lag_max; ly <= lag_max; ++ly)
        for (int lx = -lag_max; lx <= lag_max; ++lx) {
            double rl = 0.0;  // autocorrelation of the weights at lag (lx, ly)
            for (int y = -r; y <= r; ++y) {
                if (y + ly < -r || y + ly > r)
                    continue;
                for (int x = -r; x <= r; ++x)
                    if (x + lx >= -r && x + lx <= r)
                        rl += aperture.weight(x, y) * aperture.weight(x + lx, y + ly);
            }
            var += rl * cpix[static_cast<size_t>((ly + lag_max) * lag_side + lx + lag_max)];
        }
    return var / (w_total * w_total);
}

double disc_aperture_transmittance_variance(const BooleanLayer& layer, double diameter_um)
{
    const double r_um    = 0.5 * diameter_um;
    const double area    = M_PI * r_um * r_um;
    const double step_um = 0.5 * std::min(0.02, r_um / 64.0);
    const size_t steps   = static_cast<size_t>(std::ceil(std::min(layer.range_um(), diameter_um)
                                                       / step_um));
    double sum = 0.0;
    for (size_t i = 0; i < steps; ++i) {
        const double h = (static_cast<double>(i) + 0.5) * step_um;
        sum += layer.covariance(h) * lens_area_um2(r_um, h) * h;
    }
    return 2.0 * M_PI * sum * step_um / (area * area);
}

double square_transmittance_variance(const BooleanLayer& layer, int64_t side_px, double pitch_um)
{
    const int lag_max  = static_cast<int>(std::ceil(layer.range_um() / pitch_um)) + 1;
    const int lag_side = 2 * lag_max + 1;
    const std::vector<double> cpix = pixel_covariances(layer, pitch_um, lag_max);
    const double n = static_cast<double>(side_px);
    double var = 0.0;
    for (int ly = -lag_max; ly <= lag_max; ++ly)
        for (int lx = -lag_max; lx <= lag_max; ++lx) {
            // Pixel pairs of the square at this lag.
            const double pairs = std::max(0.0, n - std::abs(lx)) * std::max(0.0, n - std::abs(ly));
            var += pairs * cpix[static_cast<size_t>((ly + lag_max) * lag_side + lx + lag_max)];
        }
    return var / (n * n * n * n);
}

double siedentopf_sigma_density(double mean_grain_area_um2, double net_density,
                                double aperture_area_um2)
{
    return std::sqrt(std::max(0.0, std::log10(std::exp(1.0)) * mean_grain_area_um2 * net_density
                                       / aperture_area_um2));
}

}  // namespace filmgrain
