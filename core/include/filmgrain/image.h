// filmgrain: plain image buffers in and out of the core.
#pragma once

#include <cstdint>

namespace filmgrain {

/// A read-only view of scene-linear float pixels (MODEL.md 2). One channel
/// is read as grey (rgb = y, y, y); three or more channels are read as R, G,
/// B in the first three (alpha and others are ignored). Strides are counted
/// in floats; the defaults (0) mean packed.
///
/// The view may hold a window of a larger image: the whole image (what the
/// film frame maps to) is full_width x full_height, and the buffer holds the
/// width x height pixels starting at (x_origin, y_origin) of it. A render
/// reads only the input pixels under its ROI plus a margin
/// (required_input_window tells which); the window must cover those.
/// Defaults: the view is the whole image.
struct ImageView {
    const float* pixels = nullptr;
    int64_t width       = 0;  ///< pixels in the buffer, across
    int64_t height      = 0;  ///< pixels in the buffer, down
    int channels        = 0;
    int64_t x_stride    = 0;  ///< floats from one pixel to the next (0: channels)
    int64_t y_stride    = 0;  ///< floats from one row to the next (0: width * x_stride)
    int64_t x_origin    = 0;  ///< whole-image column of the buffer's first pixel
    int64_t y_origin    = 0;  ///< whole-image row of the buffer's first pixel
    int64_t full_width  = 0;  ///< whole image width (0: width)
    int64_t full_height = 0;  ///< whole image height (0: height)

    int64_t pixel_stride() const { return x_stride ? x_stride : channels; }
    int64_t row_stride() const { return y_stride ? y_stride : width * pixel_stride(); }
    int64_t frame_width() const { return full_width ? full_width : width; }
    int64_t frame_height() const { return full_height ? full_height : height; }
    /// The pixel at whole-image coordinates (x, y), which must lie in the
    /// window.
    const float* pixel(int64_t x, int64_t y) const
    {
        return pixels + (y - y_origin) * row_stride() + (x - x_origin) * pixel_stride();
    }
};

/// A rectangle of output pixels, [x_begin, x_end) x [y_begin, y_end), in
/// the coordinates of the full scan. Empty (all zero) means "everything".
struct Roi {
    int64_t x_begin = 0;
    int64_t y_begin = 0;
    int64_t x_end   = 0;
    int64_t y_end   = 0;

    bool empty() const { return x_end <= x_begin || y_end <= y_begin; }
    int64_t width() const { return x_end - x_begin; }
    int64_t height() const { return y_end - y_begin; }
    int64_t npixels() const { return empty() ? 0 : width() * height(); }
};

}  // namespace filmgrain
