// filmgrain CLI: reading INPUT. Which part (subimage), view and channels
// the render takes, checked from the file's header before any pixel is
// read, then the pixels of just those channels (and, with roi=, just the
// window the render reads) as float.
#pragma once

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imageio.h>

#include <string>
#include <vector>

#include "filmgrain/imagebufalgo_filmgrain.h"
#include "filmgrain/status.h"
#include "modifiers.h"

namespace filmgrain::cli {

/// What INPUT's reader is asked for (--subimage, --view, --ch).
struct InputSelection {
    /// A part by index ("0", "1", ...) or by name; empty: the first part
    /// that has the channels.
    std::string subimage;
    /// A view of a multi-view file; empty: the default view (the first of
    /// the file's multiView list, or the first part's).
    std::string view;
    /// Channel names, 3 (R, G, B) or 1 (grey), in that order; empty: R, G,
    /// B by name, else Y.
    std::vector<std::string> channels;
};

/// What the header says the render will read: the part, its spec and the
/// indices of the channels taken (3 or 1), and a description for the
/// console ("part 1 'beauty' of 2, view 'left', channels R,G,B").
struct InputHeader {
    int subimage = 0;
    OIIO::ImageSpec spec;
    std::vector<int> channels;
    std::string description;
};

/// Opens `path` and chooses its part, view and channels (InputSelection);
/// checks from the header alone, before any pixel is read, that it is a 2D
/// non-deep image within the input limits (docs/reference.md, Limits and guarantees)
/// and has the channels. Errors name the file, and when channels are
/// missing, what each part has.
Status read_input_header(const std::string& path, const InputSelection& selection,
                         InputHeader& out);

/// Reads the header's channels of `path` as float: the whole data window,
/// or with roi= only the part the render reads, so that a 256x256 ROI of a
/// 16K frame reads, converts and holds a few hundred pixels a side. The
/// buffer has the part's windows and attributes and channels named R, G, B
/// (or Y). A short read is an error.
Status read_input_pixels(const std::string& path, const InputHeader& header,
                         const FilmgrainOptions& opts, const FilmgrainCommand& cmd,
                         OIIO::ImageBuf& out);

/// Parses --ch's value ("R,G,B" or "Y"): 3 or 1 non-empty names.
Status parse_channel_list(const std::string& value, std::vector<std::string>& out);

}  // namespace filmgrain::cli
