// filmgrain-fit: a stock fitted to a datasheet's published figures (issue
// 10). The search measures every candidate analytically, the datasheet
// way (tools/sensitometry/datasheet.h: the one implementation of each
// figure), and adjusts, per layer, the grain populations (grains_per_um2,
// diameter_um, diameter_log_sigma, quantum_efficiency) and, for the whole
// stock, the latent-image rates (k_pair, k_join, k_loss of MODEL.md 3: the
// reciprocity table) and the base density (D-min).
//
// The search alternates two stages, each a derivative-free bounded search
// (NLopt's Sbplx, Rowan's subplex: deterministic):
//  A. populations, per layer, with the rates fixed: speed, slope and
//     granularity at 1/100 s (for a dye layer also its clouds' diameter
//     ratio and density, MODEL.md 8, and with inhibition its
//     self-inhibition, MODEL.md 10). The P(develop | N) table depends only on the
//     rates, the shutter and the development (MODEL.md 3-4), so it is
//     built once and every candidate costs a few milliseconds.
//  B. rates, with the populations fixed: the reciprocity figures (a table
//     per tabulated time and candidate, at a coarser Monte Carlo error).
// Each objective is the sum of squared misses in units of the issue's
// tolerance (speed 1/3 stop, slope 0.05, granularity 10%, reciprocity 1/3
// stop, 1/6 inside none_between), so 1 is "at tolerance" for one figure;
// speed, slope and granularity misses beyond 0.9 of their tolerance cost
// 10 times more (held first). A datasheet's characteristic curve adds each
// point's squared miss above D-min in units of 0.1 density, each point a
// figure.
// The result is measured again at the expected curve's full precision.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "datasheet.h"
#include "filmgrain/expected_curve.h"
#include "filmgrain/status.h"
#include "filmgrain/stock.h"

namespace filmgrain::fit {

struct FitOptions {
    /// Chooses the multi-start points (start 0 is the physical guess;
    /// later starts are jittered around it). The fit is deterministic for
    /// a seed, whatever the threads.
    uint64_t seed = 1;
    /// Grain populations per layer. [1, 4].
    int populations = 2;
    /// Largest diameter_log_sigma the search may give a population, [0.05,
    /// 0.8]. Broad sizes put the granularity in a few large grains, whose
    /// images correlate pixels further apart: the pixel scale keeps 4
    /// pixels each way (the VISION3 fits use 0.7 and stay at pixel scale
    /// in a 4K scan).
    double max_log_sigma = 0.8;
    /// Starts of the population search per layer and round, run side by
    /// side on search_curve.nthreads threads. [1, 16].
    int starts = 2;
    /// Objective evaluations per start of the population search.
    int population_evals = 500;
    /// Objective evaluations of the rate search per round (each builds a
    /// table per reciprocity time).
    int rate_evals = 60;
    /// Rounds of (populations, rates). [1, 8]. The last round ends with the
    /// populations.
    int rounds = 2;
    /// Fit the rates (when the datasheet has a reciprocity table).
    bool fit_rates = true;
    /// Tables during the search (coarser: faster) and for the final figures.
    ExpectedCurveOptions search_curve = [] {
        ExpectedCurveOptions o;
        o.target_standard_error = 5e-3;
        o.max_photons           = 1024;
        return o;
    }();
    /// Tables of the rate search: finer than search_curve, since the
    /// reciprocity tolerance (1/6 stop) is tight against the tables' noise.
    ExpectedCurveOptions rate_curve = [] {
        ExpectedCurveOptions o;
        o.target_standard_error = 3e-3;
        o.max_photons           = 1024;
        return o;
    }();
    ExpectedCurveOptions final_curve;
    /// Development and fog of the fitted stock (not searched: no figure of
    /// the datasheets separates them from the grains): d = 1 - exp(-3),
    /// fog probability 1 - exp(-360 / 20000) = 1.8%.
    double development_time_s = 360.0;
    double development_tau_s  = 120.0;
    double fog_tau_s          = 20000.0;
    /// A starting stock instead of the physical guess (its populations and
    /// rates; its layers must be the datasheet's).
    std::optional<Stock> start;
    /// Names of the layers whose populations are searched (the others keep
    /// the start's); empty: every layer of the datasheet. Needs `start`.
    std::vector<std::string> layers;
    /// The layers' image (MODEL.md 8): silver discs, or dye clouds of
    /// `cloud_profile` whose cloud_diameter_ratio and cloud_density are
    /// searched with the populations (per layer). Unset: dye for a colour
    /// negative datasheet, silver for black and white (a --start stock's
    /// own images are then kept).
    std::optional<LayerImage> image;
    CloudProfile cloud_profile = CloudProfile::gaussian;
    /// The physical guess's cloud_diameter_ratio for dye layers, [0.5, 2]
    /// (the search's range): the guess sizes each population's developed
    /// image by Siedentopf's law from the first granularity target, so its
    /// grains are that size over this ratio.
    double start_cloud_ratio = 1.0;
    /// Coupler-limited populations (Population::max_dye_density, a
    /// coupler-starved emulsion whose clouds fill rather than add): the
    /// first `coupler_limited` populations of each dye layer (the largest at
    /// the start) get a limit, searched with the populations as a fraction
    /// of the layer's cloud_density in [0.05, 1] (start 0.7); a --start
    /// stock's own limits are searched as well. Needs disc clouds. [0, 4].
    int coupler_limited = 0;
    /// Development inhibitors (MODEL.md 10, DIR couplers): each layer's
    /// self-inhibition inhibition[l][l] is searched with its populations
    /// (in [0, 1 / max_density], where every characteristic curve still
    /// rises with exposure; it lowers development where the layer is dense,
    /// the only way the model's granularity can fall with density), with the
    /// diffusion below (no datasheet figure measures it: a choice, 20 um).
    /// Unset: on for a colour negative datasheet, off for black and white
    /// (a --start stock's own inhibition is then kept).
    std::optional<bool> inhibition;
    double inhibitor_diffusion_um = 20.0;
    /// Light spread (MODEL.md 9) of the fitted stock's layers, by layer
    /// name: a layer named here gets exactly these five keys (the others
    /// keep the start's, or none). A choice: no datasheet figure measures
    /// it. The figures are read on uniform patches, where scatter moves no
    /// light and halation returns its fraction of it
    /// (Layer::uniform_field_gain), so the search runs without this spread
    /// and the result's quantum efficiencies are then divided by the gain
    /// it adds (MODEL.md 2: N_g's mean is quantum_efficiency times H):
    /// every figure stays where the search put it, to rounding.
    struct LayerSpread {
        double scatter            = 0.0;
        double scatter_sigma_um   = 0.0;
        double halation           = 0.0;
        double halation_radius_um = 0.0;  ///< disc and ring; 0 with base
        HalationKernel halation_kernel = HalationKernel::disc;
    };
    std::map<std::string, LayerSpread> light_spread;
    /// The film base the `base` halation kernel reads (the stock's
    /// base_thickness_um, base_refractive_index and rear_face: docs/model.md,
    /// "Halation from the base"), given to the fitted stock; unset: the
    /// start stock's (or none). Like the spread, a choice no figure
    /// measures.
    struct FilmBase {
        double thickness_um     = 0.0;
        double refractive_index = 1.5;
        RearFace rear_face      = RearFace::bare;
    };
    std::optional<FilmBase> film_base;
    /// Progress lines (nullptr: silent).
    std::function<void(const std::string&)> progress;
};

struct FitResult {
    Stock stock;
    sensitometry::DatasheetFigures figures;  ///< at final_curve precision
    std::vector<sensitometry::Comparison> comparisons;
    int evaluations   = 0;  ///< objective evaluations, both stages
    double seconds    = 0.0;
};

/// The stock the search starts from: one layer per datasheet layer (Y:
/// Rec. 709 luma; R, G, B: the primaries), populations sized from the
/// granularity target (Siedentopf's law gives the developed grain area),
/// MODEL.md 7's rates, exposure_at_grey_lxs = 10 / S (a normally exposed
/// grey card).
Status initial_stock(const sensitometry::Datasheet& sheet, const FitOptions& options, Stock& out);

/// Fits a stock to `sheet`. Errors: options out of range, a datasheet the
/// stock format cannot represent (colour D-min differing per layer needs a
/// per-layer base), no layers.
Status fit_stock(const sensitometry::Datasheet& sheet, const FitOptions& options, FitResult& out);

/// Measures `stock` against `sheet` at `curve` precision. A figure at a
/// density the stock never reaches (a speed point, a granularity target)
/// is a missed comparison (achieved NaN), not an error: a fit still
/// writes its stock.
Status measure(const Stock& stock, const sensitometry::Datasheet& sheet,
               const ExpectedCurveOptions& curve, sensitometry::DatasheetFigures& figures,
               std::vector<sensitometry::Comparison>& comparisons);

/// `stock`'s RMS granularity against net density at `curve` precision
/// (sensitometry::granularity_against_density).
Status granularity_curve(const Stock& stock, const sensitometry::Datasheet& sheet,
                         const ExpectedCurveOptions& curve,
                         const std::vector<double>& net_densities,
                         std::vector<std::vector<std::pair<double, sensitometry::Figure>>>& out);

/// Most grains per um^2 the search gives one population (the fit's
/// real-emulsion bound; the stock format allows 100).
inline constexpr double kMaxGrainsPerPopulationPerUm2 = 15.0;

/// The smallest RMS granularity (1000 sigma_D, 48 um aperture) that any
/// layer with at most `grains_per_um2` grains per um^2 can have at net
/// density `net2_density`, when it has `rms1` at `net1_density` <
/// net2_density, inhibition of any strength included (MODEL.md 10, every
/// entry >= 0). `above_base1_density` bounds the layer's density above its
/// base at net1 (net1 + D-min; INFINITY if unknown: a weaker bound).
///
/// Derivation (Boolean model, MODEL.md 5 and 8, P(develop) nondecreasing in
/// exposure, as the analytic figures assume). Population i develops
/// mu_i = u lambda_i P_i grains per um^2, u = exp(-sum_j inhibition[k][j]
/// Dbar_j) <= 1 falling with exposure; the density above base is
/// D = log10(e) sum_i mu_i E[b_i] (b: a grain's blocking integral), and
/// sigma_D^2 = log10(e)^2 integral w(h) (exp K(h) - 1) dh, w the aperture's
/// normalised covariance, K = sum_i mu_i E[k_i(h)], k(0) <= b. Between the
/// two exposures mu_2 = r mu_1 + u_2 Delta with r = u_2 / u_1 <= 1 and
/// Delta_i = lambda_i (P_i2 - P_i1) >= 0, sum Delta_i <= grains_per_um2:
///  - exp(r x) - 1 >= r exp(-(1 - r) x) (exp x - 1) (weighted AM-GM) with
///    x <= K_1(0) <= ln 10 D_1 gives the first term r exp(-(1 - r) ln 10 D_1)
///    sigma_1^2;
///  - exp(a + b) - 1 >= exp(a) - 1 + b and Cauchy-Schwarz (E[b^2] >= E[b]^2,
///    sum x_i E[b_i] squared <= sum x_i E[b_i]^2 sum x_i) give the second,
///    u_2 (S_2 - S_1)^2 / (grains_per_um2 A) with S = D / u (the uninhibited
///    density) and S_2 - S_1 >= net_2 / u_2 - net_1 / u_1 (fog only adds);
///    its integral takes w as 1 / A over a grain's reach: first order in
///    (cloud size / aperture), exact for grains far smaller than 48 um.
/// The smallest sum over u_1 = 1 (best) and r in (0, 1] is returned.
double smallest_granularity_after(double rms1, double net1_density, double net2_density,
                                  double grains_per_um2, double above_base1_density);

/// The smallest relative miss m that a pair of falling granularity targets
/// (t1 at net1 < net2, t2 < t1) needs, smallest_granularity_after's bound:
/// the least m with smallest_granularity_after(t1 (1 - m)) <= t2 (1 + m).
double smallest_falling_miss(double t1, double net1_density, double t2, double net2_density,
                             double grains_per_um2, double above_base1_density);

/// What no stock of the model can reach within the tolerances, from the
/// datasheet alone (one sentence each; empty if nothing). Granularity:
/// without inhibition every P(develop) grows with exposure, so K(h), the
/// Boolean model's aperture variance and the granularity grow with
/// density; targets that fall between densities a < b (t_a > t_b) then
/// miss by at least (t_a - t_b) / (t_a + t_b) (at best both are read as
/// 2 t_a t_b / (t_a + t_b)). With inhibition (`inhibited`: the stock has
/// it) the granularity can fall, by as much as smallest_falling_miss allows
/// a layer of at most `grains_per_um2[i]` grains per um^2 (datasheet layer
/// i; empty: the no-inhibition reading only). Every bound here assumes
/// images that add: none holds for a coupler-limited population, whose
/// noise falls as its clouds fill the plane (filmgrain-fit reports none for
/// such a stock).
std::vector<std::string> model_limits(const sensitometry::Datasheet& sheet, bool inhibited,
                                      const std::vector<double>& grains_per_um2);

/// A Markdown table of the comparisons (target, achieved, error, miss,
/// tolerance, met).
std::string comparison_table(const std::vector<sensitometry::Comparison>& comparisons);

}  // namespace filmgrain::fit

namespace filmgrain::fit {

/// One figure of the render check: the analytic prediction beside what
/// the render-based sensitometry (tools/sensitometry: expose_patch,
/// read_granularity; the exact engine) measures on patches of the stock.
struct RenderCheckRow {
    std::string figure;
    double analytic  = 0.0;
    double analytic_error = 0.0;  ///< the analytic figure's stated bound
    double rendered  = 0.0;
    double rendered_se = 0.0;     ///< the measurement's standard error
    /// Agreement: |rendered - analytic| <= 3 rendered_se + analytic_error
    /// (3 standard errors: a two-sided 0.27% chance to fail by noise).
    bool agrees() const;
    /// The row on one line (the render check's progress).
    std::string line() const;
};

/// Whether layer `layer` of `stock` develops independently of the other
/// layers: no other layer inhibits it (its row of MODEL.md 10's inhibition
/// is zero but for its own). Every other effect acts within a layer.
bool layer_develops_alone(const Stock& stock, size_t layer);

/// The stock reduced to layer `layer` (and its own inhibition): rendered,
/// its one layer is that layer of `stock`, bit for bit for layer 0 (grains
/// are numbered per layer index) and in distribution for any other, when
/// layer_develops_alone(stock, layer). Without the stock's Status M -> APD
/// map (it needs the layers R, G and B).
Stock layer_alone(const Stock& stock, size_t layer);

/// Renders the patches that check `figures` (from measure()) on `stock`:
/// for every datasheet layer the fog patch (D-min), the speed point (its
/// net density against the criterion), the slope's two ends, each
/// granularity density (1200 um square, 2 um pixels, the 48 um aperture
/// on the pixel grid every 12 pixels, jackknife standard error) and the
/// speed point at every reciprocity time (its net density at the exposure
/// the analytic shift predicts). Deterministic for `seed`. Each layer's
/// patches render that layer alone where layer_develops_alone. `progress`
/// receives each row as it is measured. Minutes to hours with the exact
/// engine at real emulsion scale.
Status render_check(const Stock& stock, const sensitometry::Datasheet& sheet,
                    const sensitometry::DatasheetFigures& figures, uint64_t seed, int nthreads,
                    const std::function<void(const std::string&)>& progress,
                    std::vector<RenderCheckRow>& out);

}  // namespace filmgrain::fit
