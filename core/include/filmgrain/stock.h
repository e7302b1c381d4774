// filmgrain: film stocks (MODEL.md section 6).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "filmgrain/names.h"
#include "filmgrain/status.h"

namespace filmgrain {

/// One grain population of a layer: a homogeneous Poisson process of
/// lognormal discs with its own quantum efficiency and latent-image rates
/// (MODEL.md 1-3). Defaults are the paper's scale and MODEL.md section 7.
struct Population {
    /// Grain centres per square micrometre. Range (0, 100].
    double grains_per_um2 = 0.1;
    /// Mean disc diameter, micrometres. Range [0.01, 1000].
    double diameter_um = 6.0;
    /// Log-space standard deviation of the diameter. Range [0, 1.5].
    double diameter_log_sigma = 0.3;
    /// Probability that a grain absorbs a photon landing on it. Range [0, 1].
    double quantum_efficiency = 0.05;
    /// Pairing rate constant (two free electrons -> 2-centre), 1/s. [0, 1e15].
    double k_pair_per_s = 1e7;
    /// Growth rate constant (electron joins a centre), 1/s. [0, 1e15].
    double k_join_per_s = 1e6;
    /// Loss rate constant (recombination, other traps), 1/s. [0, 1e15].
    double k_loss_per_s = 10.0;
    /// Rates scale per grain by (area / mean area)^(-exponent). [-4, 4].
    double rate_area_exponent = 0.0;
    /// For a dye layer with disc clouds: the coupler limit, the most dye
    /// density this population's clouds form at a point (docs/model.md,
    /// "Coupler-limited populations"): where any of its clouds lies, its
    /// density is max_dye_density, however many overlap (a coupler-starved
    /// emulsion: overlapping clouds share the coupler, they do not add).
    /// 0: no limit, its clouds add (MODEL.md 8). Range [0, 20]; when > 0 at
    /// most the layer's cloud_density.
    double max_dye_density = 0.0;

    /// Whether the population's clouds fill up to a coupler limit rather
    /// than add.
    bool coupler_limited() const { return max_dye_density > 0.0; }
};

/// The shape of a layer's halation kernel (MODEL.md 9), each normalised to
/// unit integral: `disc`, uniform inside halation_radius_um; `ring`, uniform
/// on the annulus between kRingInnerFraction * halation_radius_um and
/// halation_radius_um (light reflected from the base's rear surface comes
/// back concentrated near the radius); `base`, the glow the film base
/// returns (docs/model.md, "Halation from the base"), its size and shape
/// computed from the stock's base_thickness_um, base_refractive_index and
/// rear_face (halation_radius_um is then 0).
enum class HalationKernel { disc, ring, base };

/// Inner radius of the `ring` halation kernel, as a fraction of its radius.
inline constexpr double kRingInnerFraction = 0.75;

inline constexpr Named<HalationKernel> kHalationKernelNames[] = {
    { HalationKernel::disc, "disc" }, { HalationKernel::ring, "ring" },
    { HalationKernel::base, "base" }
};
constexpr const auto& names_of(HalationKernel) { return kHalationKernelNames; }

/// What lies behind the film base's rear face (docs/model.md, "Halation
/// from the base"): `remjet`, an absorbing backing in optical contact with
/// the base (no step to air: light that reaches the face crosses into the
/// backing and is absorbed, at every angle alike); `bare`, air (Fresnel
/// reflection below the critical angle, total internal reflection above).
enum class RearFace { remjet, bare };

inline constexpr Named<RearFace> kRearFaceNames[] = { { RearFace::remjet, "remjet" },
                                                     { RearFace::bare, "bare" } };
constexpr const auto& names_of(RearFace) { return kRearFaceNames; }

/// What a layer's developed grains leave (MODEL.md 8): opaque silver discs
/// (section 5), or clouds of dye whose densities add.
enum class LayerImage { silver, dye };
/// A dye cloud's profile: `disc`, uniform density inside its radius;
/// `gaussian`, density exp(-2 (distance / radius)^2) of its peak.
enum class CloudProfile { disc, gaussian };

inline constexpr Named<LayerImage> kLayerImageNames[] = { { LayerImage::silver, "silver" },
                                                         { LayerImage::dye, "dye" } };
inline constexpr Named<CloudProfile> kCloudProfileNames[] = { { CloudProfile::disc, "disc" },
                                                             { CloudProfile::gaussian,
                                                               "gaussian" } };
constexpr const auto& names_of(LayerImage) { return kLayerImageNames; }
constexpr const auto& names_of(CloudProfile) { return kCloudProfileNames; }

/// One emulsion layer: an output channel.
struct Layer {
    /// Output channel name (non-empty, unique within the stock).
    std::string name = "Y";
    /// Weights on scene-linear RGB giving the layer's exposure value v.
    /// Each in [0, 100], not all zero.
    std::array<double, 3> sensitivity = { 0.2126, 0.7152, 0.0722 };
    /// At least one population.
    std::vector<Population> populations = std::vector<Population>(1);

    /// This layer's own minimum density (a colour negative's mask in this
    /// layer's channel), added to the stock's base_density. Range [0, 10].
    double base_density = 0.0;

    /// MODEL.md 9, light spread in the film before photons are counted.
    /// Fraction of the light scattered sideways. Range [0, 1].
    double scatter = 0.0;
    /// Standard deviation of the scatter's Gaussian, micrometres on the
    /// film. Range [0, 1000]; > 0 when scatter > 0.
    double scatter_sigma_um = 0.0;
    /// Fraction of the (scattered) light reflected back into the layer from
    /// the base. Range [0, 1].
    double halation = 0.0;
    /// Radius of the `disc` and `ring` halation kernels, micrometres on the
    /// film. Range [0, 5000]; > 0 when halation > 0 with those kernels, 0
    /// with `base` (whose size follows from the stock's film base).
    double halation_radius_um = 0.0;
    HalationKernel halation_kernel = HalationKernel::disc;

    /// MODEL.md 8: `silver` (opaque discs) or `dye` (clouds).
    LayerImage image = LayerImage::silver;
    /// For dye: the clouds' profile.
    CloudProfile cloud_profile = CloudProfile::disc;
    /// For dye: cloud radius over grain radius. Range [0.1, 10].
    double cloud_diameter_ratio = 1.0;
    /// For dye: a cloud's peak density. Range (0, 20].
    double cloud_density = 1.0;

    /// Whether the layer scatters light / has a halo (MODEL.md 9): a
    /// fraction and a width both above 0 (for the `base` kernel the width
    /// is the stock's base_thickness_um, > 0 in a valid stock).
    bool scatters() const { return scatter > 0.0 && scatter_sigma_um > 0.0; }
    bool halates() const
    {
        return halation > 0.0
               && (halation_kernel == HalationKernel::base || halation_radius_um > 0.0);
    }

    /// Whether the layer's exposure is spread at all (MODEL.md 9): a layer
    /// without spread is rendered exactly as before the keys existed.
    bool spreads_light() const { return scatters() || halates(); }

    /// MODEL.md 9 on a uniform field: H' = gain * H, gain = 1 + halation
    /// (the halation kernel returns its fraction of the light; scatter only
    /// moves light). What a datasheet figure, read on uniform patches, sees
    /// of the spread.
    double uniform_field_gain() const { return halates() ? 1.0 + halation : 1.0; }

    /// The layer's exposure value per unit of a uniform neutral grey: MODEL.md
    /// 2's v = dot(sensitivity, (y, y, y)), the sum of the weights, times
    /// uniform_field_gain().
    double neutral_weight() const
    {
        return (sensitivity[0] + sensitivity[1] + sensitivity[2]) * uniform_field_gain();
    }
};

/// MODEL.md 11: how a colour stock's Status M densities (the datasheet
/// curves' reader, what the layers' densities are) read in Academy
/// Printing Density: APD = matrix * StM + offset on absolute densities,
/// channels R, G, B (the layers named R, G and B), as A.M.P.A.S.
/// S-2008-002 v1.1 Annex C publishes it per stock (a least-squares fit over
/// 97 spectrally measured patches). The stock file's key is
/// `printing_density: { status_m_to_apd: { matrix: [[3x3]], offset: [3] } }`
/// (stocks/datasheets/README.md). The maths is in
/// filmgrain/printing_density.h.
struct StatusMToApd {
    /// Rows: APD R, G, B out; columns: Status M R, G, B in. Each entry in
    /// [-10, 10].
    std::array<std::array<double, 3>, 3> matrix {};
    /// Density added after the matrix, R, G, B. Each in [-10, 10].
    std::array<double, 3> offset {};
};

/// The scene-linear value of MODEL.md 2's 18% grey card: it receives a
/// stock's exposure_at_grey_lxs, and ADX's timing (MODEL.md 11) puts the
/// stock's density of it on CDD 0.70.
inline constexpr double kGreyValue = 0.18;

/// A film stock: its layers and its processing (MODEL.md 2, 4, 5).
struct Stock {
    std::string name        = "unnamed";
    std::string description = "";
    /// Exposure (lux-seconds) that a scene-linear 0.18 grey receives at
    /// exposure offset 0. Range (0, 1e6].
    double exposure_at_grey_lxs = 0.01;
    /// Development time, seconds. Range [0, 1e7].
    double development_time_s = 360.0;
    /// Development efficiency time constant: d = 1 - exp(-t / tau). (0, 1e12].
    double development_tau_s = 120.0;
    /// Fog time constant: f = 1 - exp(-t / fog_tau). Range (0, 1e30].
    double fog_tau_s = 5000.0;
    /// Density added to every pixel of every layer (film base); each layer
    /// may add its own (Layer::base_density). Range [0, 10].
    double base_density = 0.0;
    /// Clamp of the density computed from transmittance. Range (0, 20].
    double max_density = 4.0;
    /// One to 16 layers.
    std::vector<Layer> layers = { Layer() };
    /// MODEL.md 10, development inhibitors: inhibition[k][j] is how strongly
    /// layer j's expected developed density (blurred) holds back development
    /// in layer k: P -> P exp(-sum_j inhibition[k][j] Dbar_j). One row per
    /// layer, one column per layer, each in [0, 10]; empty means all zero
    /// (no inhibition; an all-zero matrix is stored empty).
    std::vector<std::vector<double>> inhibition;
    /// Standard deviation of the inhibitors' diffusion, micrometres on the
    /// film. Range [0, 1000].
    double inhibitor_diffusion_um = 0.0;
    /// The film base under the emulsion, read by the `base` halation kernel
    /// (docs/model.md, "Halation from the base"); one base for every layer.
    /// Its thickness, micrometres: range [0, 2000]; > 0 when a layer with
    /// halation > 0 uses the `base` kernel (0: not given).
    double base_thickness_um = 0.0;
    /// Its refractive index: range [1.3, 2] (cellulose triacetate ~1.48,
    /// polyester ~1.65).
    double base_refractive_index = 1.5;
    /// What lies behind its rear face.
    RearFace rear_face = RearFace::bare;
    /// MODEL.md 11: the stock's Status M -> APD map (key `printing_density`),
    /// or none: the stock then reads APD = Status M (said in the outputs'
    /// metadata). Only for a stock with layers named R, G and B.
    std::optional<StatusMToApd> status_m_to_apd;

    /// Whether any inhibition is on: without, development is MODEL.md 4's.
    bool inhibits() const;

    /// The density layer `layer`'s pixels start from (MODEL.md 5's
    /// base_density): the stock's base_density plus the layer's own.
    double layer_base_density(size_t layer) const
    {
        return base_density + layers[layer].base_density;
    }

    /// Check every field against its range; the message names the field
    /// (as a JSON path such as layers[1].populations[0].diameter_um), its
    /// value and the allowed range.
    Status validate() const;
};

/// Parse a stock from JSON text (MODEL.md 6). Unknown keys, wrong types and
/// out-of-range values are errors naming the key; absent keys take the
/// defaults above. `origin` (a file name or "preset NAME") prefixes errors.
/// The result is validated.
Status parse_stock_json(const std::string& text, const std::string& origin, Stock& out);

/// The stock as JSON text with every key present (the full, resolved stock):
/// what goes into output metadata. parse_stock_json(stock_to_json(s)) == s.
std::string stock_to_json(const Stock& stock, int indent = -1);

/// Names of the built-in presets, the default first.
std::vector<std::string> preset_names();

/// The name of the default preset (the three-layer colour negative).
const char* default_preset_name();

/// The JSON text of a built-in preset, or an empty string if unknown.
std::string preset_json(const std::string& name);

/// Load a built-in preset by name, or else a JSON file by path.
Status load_stock(const std::string& name_or_path, Stock& out);

}  // namespace filmgrain
