// filmgrain-fit's choices for the options a user leaves unset: what a
// datasheet's kind and figures need (issue 43: "defaults that work"). They
// are the recipes docs/stocks gave by hand for the built-in stocks, each
// with the reason it is chosen, so that `filmgrain-fit SHEET -o STOCK` with
// no options fits a stock of that kind; every option still overrides its
// choice.
#pragma once

#include <string>
#include <vector>

#include "datasheet.h"
#include "fit.h"

namespace filmgrain::fit {

/// The options filmgrain-fit chooses for a datasheet, and why.
struct FitRecipe {
    /// The library's defaults with the recipe's choices: populations,
    /// starts, population_evals, rounds, max_log_sigma, cloud_profile,
    /// coupler_limited, start_cloud_ratio, and the construction no
    /// datasheet figure measures (MODEL.md 9: light_spread, film_base).
    FitOptions options;
    /// One line per choice: what it is and why (the fit's progress).
    std::vector<std::string> reasons;
};

/// The largest ratio of two layers' RMS granularities read at the same
/// net density: the lowest net density at which every layer has a target
/// (1 when the layers share none, or there is one layer).
double granularity_spread_across_layers(const sensitometry::Datasheet& sheet);

/// At or above this granularity_spread_across_layers the physical guess's
/// dye clouds start at twice their grain (start_cloud_ratio 2): a layer
/// much grainier than its neighbours at the same density has large
/// developed images, which the search (cloud ratio 0.5 to 2) reached
/// from 2 and not from 1 for VISION3 500T (spread 3.5: its blue stayed at
/// granularity 19.5 for 25.1); 250D (spread 1.8) fits from 1. A choice
/// between those two datasheets.
inline constexpr double kBigCloudGranularitySpread = 2.5;

/// What `sheet`'s kind ("bw-negative", "colour-negative") and figures ask
/// for. Black and white: four silver populations and three rounds (Tri-X's
/// reciprocity needed the third). Colour negative: four populations of
/// disc dye clouds, the two largest coupler-limited, diameter log sigma at
/// most 0.7 (the pixel scale keeps such grains in a 4K scan), four starts
/// of 1,500 evaluations, the clouds' start by
/// granularity_spread_across_layers, and a motion-picture negative's
/// construction (VISION3's scatter, halation from a 125 um base with a
/// rem-jet backing; docs/model.md). Other kinds: the library's FitOptions
/// defaults, said in `reasons`.
FitRecipe recipe_for(const sensitometry::Datasheet& sheet);

}  // namespace filmgrain::fit
