#include "filmgrain/chart.h"

#include <algorithm>
#include <cmath>

namespace filmgrain {

namespace {

/// One ColorChecker patch: its name and its 8-bit sRGB (D65) code values.
struct ColorCheckerPatch {
    const char* name;
    int srgb[3];
};

/// The 24 patches in reading order, with the 8-bit sRGB (IEC 61966-2-1,
/// D65) values X-Rite publishes for the ColorChecker Classic of the
/// post-2009 formulation; BabelColor's averaged spectral measurements give
/// the same values (D. Pascale, ColorChecker_RGB_and_spectra.xls,
/// www.babelcolor.com; method in his "RGB coordinates of the Macbeth
/// ColorChecker", 2006).
constexpr ColorCheckerPatch kColorChecker[kChartPatches] = {
    { "dark skin", { 115, 82, 68 } },
    { "light skin", { 194, 150, 130 } },
    { "blue sky", { 98, 122, 157 } },
    { "foliage", { 87, 108, 67 } },
    { "blue flower", { 133, 128, 177 } },
    { "bluish green", { 103, 189, 170 } },
    { "orange", { 214, 126, 44 } },
    { "purplish blue", { 80, 91, 166 } },
    { "moderate red", { 193, 90, 99 } },
    { "purple", { 94, 60, 108 } },
    { "yellow green", { 157, 188, 64 } },
    { "orange yellow", { 224, 163, 46 } },
    { "blue", { 56, 61, 150 } },
    { "green", { 70, 148, 73 } },
    { "red", { 175, 54, 60 } },
    { "yellow", { 231, 199, 31 } },
    { "magenta", { 187, 86, 149 } },
    { "cyan", { 8, 133, 161 } },
    { "white 9.5", { 243, 243, 242 } },
    { "neutral 8", { 200, 200, 200 } },
    { "neutral 6.5", { 160, 160, 160 } },
    { "neutral 5", { 122, 122, 121 } },
    { "neutral 3.5", { 85, 85, 85 } },
    { "black 2", { 52, 52, 52 } },
};

/// An 8-bit sRGB code value to linear (IEC 61966-2-1's decoding: linear
/// below 0.04045, else the 2.4 power). sRGB and Rec.709 share primaries and
/// white, so this is linear Rec.709.
double srgb8_to_linear(int code)
{
    const double v = code / 255.0;
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
}

/// Fills pixels x in [x0, x1), y in [y0, y1), clipped to the image, with rgb.
void fill_rect(std::vector<float>& pixels, int64_t width, int64_t height, int64_t x0, int64_t y0,
               int64_t x1, int64_t y1, const float rgb[3])
{
    x0 = std::max<int64_t>(x0, 0), y0 = std::max<int64_t>(y0, 0);
    x1 = std::min(x1, width), y1 = std::min(y1, height);
    for (int64_t y = y0; y < y1; ++y)
        for (int64_t x = x0; x < x1; ++x)
            std::copy(rgb, rgb + 3, pixels.begin() + (y * width + x) * 3);
}

/// Fills the pixels whose integer offsets from (cx, cy) have dx^2 + dy^2
/// <= r^2, clipped to the image, with the grey `v`.
void fill_disc(std::vector<float>& pixels, int64_t width, int64_t height, int64_t cx, int64_t cy,
               int64_t r, float v)
{
    for (int64_t dy = -r; dy <= r; ++dy)
        for (int64_t dx = -r; dx <= r; ++dx) {
            const int64_t x = cx + dx, y = cy + dy;
            if (dx * dx + dy * dy <= r * r && x >= 0 && x < width && y >= 0 && y < height)
                std::fill_n(pixels.begin() + (y * width + x) * 3, 3, v);
        }
}

}  // namespace

double ChartSpec::level(double stops)
{
    return 0.18 * std::exp2(stops);
}

int64_t ChartSpec::patch_x_px(int i) const
{
    const int64_t block = 6 * patch_px + 5 * patch_gap_px;
    const int64_t x0    = 2 * third_px() + (width_px - 2 * third_px() - block) / 2;
    return x0 + (i % 6) * (patch_px + patch_gap_px);
}

int64_t ChartSpec::patch_y_px(int i) const
{
    const int64_t block = 4 * patch_px + 3 * patch_gap_px;
    const int64_t y0    = (height_px - block) / 2;
    return y0 + (i / 6) * (patch_px + patch_gap_px);
}

std::vector<float> make_look_chart(const ChartSpec& spec)
{
    const int64_t w = spec.width_px, h = spec.height_px;
    if (w <= 0 || h <= 0)
        return {};
    std::vector<float> pixels(static_cast<size_t>(w * h * 3),
                              static_cast<float>(ChartSpec::level(spec.ground_stops)));

    const float grey = static_cast<float>(ChartSpec::level(spec.rect_stops));
    const float rect_rgb[3] = { grey, grey, grey };
    fill_rect(pixels, w, h, spec.rect_x0_px(), spec.rect_y0_px(), spec.rect_x1_px(),
              spec.rect_y1_px(), rect_rgb);

    for (int i = 0; i < kChartPatches; ++i) {
        float rgb[3];
        for (int c = 0; c < 3; ++c)
            rgb[c] = static_cast<float>(srgb8_to_linear(kColorChecker[i].srgb[c]));
        const int64_t x = spec.patch_x_px(i), y = spec.patch_y_px(i);
        fill_rect(pixels, w, h, x, y, x + spec.patch_px, y + spec.patch_px, rgb);
    }

    fill_disc(pixels, w, h, spec.point_x_px(), spec.point_y_px(), spec.point_radius_px,
              static_cast<float>(ChartSpec::level(spec.point_stops)));
    fill_disc(pixels, w, h, spec.point_x_px(), spec.dim_point_y_px(), spec.point_radius_px,
              static_cast<float>(ChartSpec::level(spec.dim_point_stops)));
    return pixels;
}

}  // namespace filmgrain
