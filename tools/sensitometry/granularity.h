// filmgrain sensitometry: granularity as a microdensitometer reads it: the
// standard deviation of density through a circular aperture scanned over a
// uniformly exposed patch (the datasheet "diffuse RMS granularity" uses a
// 48 um aperture at mean density 1.0 and quotes sigma_D x 1000).
#pragma once

#include <cstdint>
#include <vector>

#include "expect/boolean_model.h"

namespace filmgrain::sensitometry {

/// Granularity of one patch through one aperture.
struct GranularityReading {
    double aperture_diameter_um = 0.0;
    /// Area of the aperture as sampled on the pixel grid, um^2.
    double aperture_area_um2 = 0.0;
    /// Aperture positions read (centres on a square grid).
    int64_t positions = 0;
    /// Mean of the aperture densities, base included.
    double mean_density = 0.0;
    /// sigma_D: standard deviation of D_A = -log10(T_A) + base, where T_A is
    /// the mean transmittance through the aperture (the flux it passes).
    double sigma_density = 0.0;
    /// Standard error of sigma_density: jackknife over blocks of the patch.
    double sigma_density_se = 0.0;
    /// Relative standard deviation of T_A, sigma_T / mean T.
    double relative_sigma_transmittance = 0.0;
    double relative_sigma_transmittance_se = 0.0;
    /// Selwyn's coefficient G = sigma_D sqrt(2 A), um.
    double selwyn_um() const;
};

/// Reads the granularity of a patch: `transmittance` holds side_px x
/// side_px pixel transmittances (base excluded) of pitch `aperture.pitch_um`.
/// Aperture centres lie on pixel centres every `spacing_px` pixels, with the
/// whole aperture inside the patch. The patch is cut into blocks x blocks
/// squares (each position belongs to the block of its centre); the
/// standard errors are leave-one-block-out jackknife estimates.
GranularityReading read_granularity(const std::vector<double>& transmittance, int64_t side_px,
                                    const ApertureTemplate& aperture, int spacing_px,
                                    double base_density, int blocks = 4);

}  // namespace filmgrain::sensitometry
