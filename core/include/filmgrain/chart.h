// filmgrain: the built-in look chart, a scene for judging halation, the
// adjacency effect and colour rendition by eye.
#pragma once

#include <cstdint>
#include <vector>

namespace filmgrain {

/// The look chart: a packed RGB scene-linear image (lin_rec709, the
/// config's scene_linear role) with, on a dark ground, something to judge
/// each of three film effects in a preview. Levels are stops relative to
/// scene grey, value = 0.18 * 2^stops. With the defaults (1536 x 768 px):
///
///     +----------------+----------------+--------------------+
///     |                |                |  1  2  3  4  5  6  |
///     |       o        |   +--------+   |  7  8  9 10 11 12  |
///     |                |   |  grey  |   | 13 14 15 16 17 18  |
///     |       .        |   +--------+   | 19 20 21 22 23 24  |
///     |                |                |                    |
///     +----------------+----------------+--------------------+
///
/// - Ground: 0.18 * 2^-6 everywhere not covered below.
/// - Left third: a point light, a disc of radius `point_radius_px` (3 px)
///   at 0.18 * 2^+10, far over the film's shoulder, centred at
///   (point_x_px(), point_y_px()) = (256, 256); below it a dimmer one,
///   same radius, at 0.18 * 2^+6, centred at (point_x_px(),
///   dim_point_y_px()) = (256, 512). A pixel belongs to a disc when the
///   integer offsets (dx, dy) from the centre pixel have dx^2 + dy^2 <=
///   r^2 (29 pixels for r = 3). Halation shows as a (red) glow around them.
/// - Middle third: a sharp-edged rectangle at 0.18 (grey), pixels x in
///   [rect_x0_px(), rect_x1_px()) = [576, 960), y in [rect_y0_px(),
///   rect_y1_px()) = [192, 576): its edges show the adjacency effect (on the
///   negative, a denser rim just inside and a thinner one just outside)
///   and halation's spill onto the ground.
/// - Right third: the 24-patch ColorChecker, 6 columns x 4 rows in the
///   chart's reading order (patch 1 dark skin top left, 19 white 9.5 bottom
///   left, 24 black 2 bottom right), patches `patch_px` square (72) with
///   `patch_gap_px` (8) of ground between them, the block centred in the
///   right third: patch 1 at (1044, 228). Values: the published 8-bit sRGB
///   (D65) values, linearised with the sRGB transfer function (chart.cpp
///   cites them), i.e. linear Rec.709 reflectances (white 9.5 ~0.90,
///   neutral 5 ~0.19).
///
/// Other sizes scale the thirds, the point and rectangle positions with the
/// image; the patches keep their size and are clipped to the image.
///
/// Like the wedge, the chart is a test strip, not a camera frame: its
/// pixels are 6.25 um on a strip `strip_width_mm` wide (width_px * 6.25 um,
/// 9.6 mm), so that grains are visible in its scan. A render may still put
/// it on any width.
struct ChartSpec {
    int64_t width_px       = 1536;
    int64_t height_px      = 768;
    double strip_width_mm  = 9.6;  ///< width_px pixels of 6.25 um

    double ground_stops    = -6.0;
    double point_stops     = 10.0;
    double dim_point_stops = 6.0;
    double rect_stops      = 0.0;
    int64_t point_radius_px = 3;
    int64_t patch_px       = 72;
    int64_t patch_gap_px   = 8;

    /// The scene-linear value of a level `stops` relative to grey:
    /// 0.18 * 2^stops.
    static double level(double stops);

    int64_t third_px() const { return width_px / 3; }
    int64_t point_x_px() const { return third_px() / 2; }
    int64_t point_y_px() const { return height_px / 3; }
    int64_t dim_point_y_px() const { return 2 * height_px / 3; }
    int64_t rect_x0_px() const { return third_px() + third_px() / 8; }
    int64_t rect_x1_px() const { return 2 * third_px() - third_px() / 8; }
    int64_t rect_y0_px() const { return height_px / 4; }
    int64_t rect_y1_px() const { return 3 * height_px / 4; }
    /// Top-left pixel of ColorChecker patch `i`, 0-based in reading order
    /// (0: dark skin, 18: white 9.5, 23: black 2); may lie outside the image
    /// for sizes too small to hold the block.
    int64_t patch_x_px(int i) const;
    int64_t patch_y_px(int i) const;
};

/// Number of ColorChecker patches on the chart.
constexpr int kChartPatches = 24;

/// The chart as a packed 3-channel (R, G, B) scene-linear image, row by
/// row: width_px x height_px x 3 floats. A pure function of `spec`
/// (bit-identical for equal specs); empty when a size is not positive.
std::vector<float> make_look_chart(const ChartSpec& spec);

}  // namespace filmgrain
