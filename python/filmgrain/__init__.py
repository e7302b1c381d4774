"""filmgrain: physically based per-grain film simulation, from Python.

The same simulator as the ``filmgrain`` command-line tool, through the same
OpenImageIO operator: for the same pixels and settings, :func:`render`
returns exactly the pixels (bit for bit) and the statistics that
``filmgrain INPUT --filmgrain:... -o OUT.exr --stats STATS.json`` writes.

Functions:
    render(pixels, ...)          scene-linear float32 array -> negative density
    render_imagebuf(buf, ...)    the same for an OpenImageIO ImageBuf
    to_imagebuf(negative)        a render's result as an OpenImageIO ImageBuf
    stocks()                     the built-in film stock presets
    stock(name_or_path)          a stock as a dict (to modify and pass back)

Errors of the simulator (bad settings, stocks, regions) raise
:class:`filmgrain.Error`, a ``ValueError`` whose message is the core's, as
the CLI prints it. Wrong Python types raise ``TypeError``.

Thread safety: renders may run concurrently from several Python threads;
the GIL is released while a render runs. Ctrl-C (KeyboardInterrupt) cancels
a render within about a tenth of a second.
"""

import json
import numbers
import os
import sys
import warnings

import numpy as np

from . import _filmgrain

__all__ = [
    "Error",
    "Negative",
    "render",
    "render_imagebuf",
    "stock",
    "stocks",
    "to_imagebuf",
    "__version__",
]

__version__ = _filmgrain.version()

#: Raised for every failure the simulator reports (a ``ValueError``). Its
#: message is the core's, as the ``filmgrain`` CLI prints it.
Error = _filmgrain.Error
Error.__module__ = __name__

# Option name in the modifier string: messages of the CLI's parser start
# with it ("filmgrain.render: exposure_stops=100: ...", where the CLI says
# "--filmgrain: exposure_stops=100: ...").
_OPTION = "filmgrain.render"


class Negative:
    """The result of a render: negative density and what the render did.

    Unpacks as a pair: ``density, stats = filmgrain.render(...)``.

    Attributes:
        density: float32 array (height, width, layers) of the rendered
            region (the ``roi``, else the whole scan): negative density,
            -log10(transmittance) plus the stock's base density, one layer
            per stock layer in stock order (e.g. R, G, B).
        stats: the ``--stats`` document of the CLI as a dict (engine, seed,
            grain_seed, scan, roi, input, layers with grain counts, ...);
            ``stats["input"]["file"]`` is ``"<array>"``.
        channels: the layer names, in the order of ``density``'s last axis.
        attributes: the ``filmgrain:*`` metadata the operator writes into
            the EXR header (name -> str, int or float).
        roi: (x, y, width, height) of the rendered region in scan pixels.
        scan: (width, height) of the whole scan, pixels.
    """

    __slots__ = ("density", "stats", "channels", "attributes", "roi", "scan")

    def __init__(self, density, stats, channels, attributes, roi, scan):
        self.density = density
        self.stats = stats
        self.channels = tuple(channels)
        self.attributes = dict(attributes)
        self.roi = tuple(roi)
        self.scan = tuple(scan)

    def __iter__(self):
        return iter((self.density, self.stats))

    def __len__(self):
        return 2

    def __repr__(self):
        h, w, _ = self.density.shape
        return (
            f"<filmgrain.Negative {w}x{h} of the {self.scan[0]}x{self.scan[1]} scan, "
            f"layers {','.join(self.channels)}, stock {self.stats.get('stock')!r}>"
        )


def stocks():
    """Names of the built-in film stock presets, the default first.

    The same list as ``filmgrain --list-stocks``. Pass a name as
    ``render(..., stock=NAME)``; :func:`stock` returns a preset's settings.
    """
    return list(_filmgrain.preset_names())


def stock(name_or_path=None):
    """A film stock as a dict with every key present.

    name_or_path: a preset name (see :func:`stocks`), a path to a stock
    JSON file (str or os.PathLike), or None for the default preset.
    Modify the dict and pass it back as ``render(..., stock=the_dict)``.
    Raises filmgrain.Error when the stock cannot be loaded.
    """
    if name_or_path is None:
        name_or_path = _filmgrain.default_preset_name()
    return json.loads(_filmgrain.stock_json(_stock_name(name_or_path)))


def _stock_name(value):
    if isinstance(value, (str, os.PathLike)):
        return os.fspath(value)
    raise TypeError(
        f"stock={value!r}: expected a preset name, a stock JSON file path or a dict, "
        f"not {type(value).__name__}"
    )


def _format_value(key, value):
    """One modifier value in the CLI's syntax. Numbers round-trip exactly:
    floats as repr (the shortest string that reads back as the same double),
    integers in decimal; strings pass unchanged (e.g. shutter_s="1/48")."""
    if isinstance(value, bool):
        if key == "static_grain":
            return "1" if value else "0"
        raise TypeError(f"{key}={value!r}: expected a number or a string, not a bool")
    if isinstance(value, numbers.Integral):
        text = str(int(value))
    elif isinstance(value, numbers.Real):
        text = repr(float(value))
    elif isinstance(value, str):
        text = value
    elif key in ("scan", "roi") and isinstance(value, (tuple, list)):
        sep = "x" if key == "scan" else ","
        parts = []
        for v in value:
            if isinstance(v, bool) or not isinstance(v, numbers.Integral):
                raise TypeError(f"{key}={value!r}: expected whole numbers, got {v!r}")
            parts.append(str(int(v)))
        text = sep.join(parts)
    else:
        raise TypeError(
            f"{key}={value!r}: expected a number or a string, not {type(value).__name__}"
        )
    if ":" in text:
        raise ValueError(
            f"{key}={value!r}: a value cannot contain ':' (it separates the CLI's modifiers)"
        )
    return text


_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))


def _outside_stacklevel():
    """warnings.warn's stacklevel for a warning issued by the function that
    calls this one, naming the first caller outside this package: the
    user's code, whatever the depth of the package's own calls between."""
    frame, level = sys._getframe(1), 1
    while (frame is not None
           and os.path.dirname(os.path.abspath(frame.f_code.co_filename)) == _PACKAGE_DIR):
        frame, level = frame.f_back, level + 1
    return level


def _renamed(modifiers):
    """modifiers with the CLI's renamed modifiers (exposure, shutter,
    static: now exposure_stops, shutter_s, static_grain) under their new
    names, each old name given warned of (DeprecationWarning)."""
    out = dict(modifiers)
    for old, new in _filmgrain.renamed_modifiers():
        if out.get(old) is None:
            out.pop(old, None)
            continue
        if out.get(new) is not None:
            raise TypeError(f"{old}= and {new}= name the same modifier ({old} is its old name)")
        warnings.warn(f"filmgrain: {old}= is now {new}= (the old name is still read)",
                      DeprecationWarning, stacklevel=_outside_stacklevel())
        out[new] = out.pop(old)
    return out


def _modifier_string(modifiers):
    parts = [_OPTION]
    for key, value in _renamed(modifiers).items():
        if value is None:
            continue
        if not isinstance(key, str) or not key or ":" in key or "=" in key:
            raise TypeError(f"{key!r} is not a modifier name")
        parts.append(f"{key}={_format_value(key, value)}")
    return ":".join(parts)


def _as_image(pixels):
    """pixels as a C-contiguous float32 (height, width, channels) array."""
    if not isinstance(pixels, np.ndarray):
        raise TypeError(
            f"pixels: expected a numpy.ndarray of float32, not {type(pixels).__name__}"
        )
    if pixels.dtype != np.float32:
        raise TypeError(
            f"pixels has dtype {pixels.dtype}: filmgrain.render takes float32 scene-linear "
            f"pixels; convert explicitly, e.g. pixels.astype(numpy.float32)"
        )
    if pixels.ndim == 2:
        pixels = pixels[:, :, np.newaxis]
    elif pixels.ndim != 3:
        raise ValueError(
            f"pixels has shape {pixels.shape}: expected (height, width) or "
            f"(height, width, channels)"
        )
    return np.ascontiguousarray(pixels)


def render(
    pixels,
    *,
    stock=None,
    exposure_stops=None,
    shutter_s=None,
    seed=None,
    frame=None,
    static_grain=None,
    edge=None,
    width_mm=None,
    scan=None,
    roi=None,
    engine=None,
    tolerance=None,
    tile=None,
    output=None,
    timing=None,
    ocolorspace=None,
    colorconfig=None,
    threads=0,
    progress=None,
    **expert,
):
    """Exposes, develops and scans a film negative of a scene-linear image.

    The Python form of ``filmgrain INPUT --filmgrain:key=value... -o OUT.exr
    --stats STATS.json``; for the same pixels and settings the density is
    bit-identical to the CLI's EXR and the statistics equal its --stats
    (except timings and ``input.file``). Every keyword but ``stock``,
    ``threads`` and ``progress`` is a ``--filmgrain`` modifier, parsed and
    checked by the CLI's own parser; None (the default) means the CLI's
    default, listed below.

    Args:
        pixels: numpy.ndarray of float32, scene-linear (no colour conversion
            is done: convert other colour spaces first), shape (height,
            width) or (height, width, 1) for grey, or (height, width, C)
            with C >= 3 (R, G, B first; further channels are ignored). Other
            dtypes raise TypeError (no silent conversion: use
            ``pixels.astype(numpy.float32)``); non-contiguous arrays are
            copied; 2 channels raise filmgrain.Error. The film frame covers
            the whole array, square pixels. Do not modify the array while
            the render runs.
        stock: the film: a preset name (:func:`stocks`), a stock JSON file
            path (str or os.PathLike, ':' allowed), or a dict in the stock
            JSON format (e.g. from :func:`stock`, modified; absent keys take
            the defaults). Default: the default preset.
        exposure_stops: exposure offset, stops (float), [-64, 64].
        shutter_s: shutter time, seconds (float, or a string fraction
            "1/48"), (0, 1e7].
        seed: grain pattern, int in [0, 2**64 - 1].
        frame: frame number of a sequence, int in [-1e9, 1e9]: the grain
            of frame N is frame_seed(seed, N), the same as the CLI's
            ``frame=N`` and ``--frames``. Default: a single image.
        static_grain: with frame: True keeps one grain pattern on every
            frame.
        edge: beyond the image (MODEL.md 2): "clamp" (the default: the
            scene continues, each point exposed as the nearest edge pixel)
            or "gate" (no light: a camera gate's hard edge).
        width_mm: width of the film frame, millimetres (float), (0, 1e9].
        scan: output size over the whole frame: (width, height), width
            (int: the frame's aspect) or "WxH". Default: the input's size.
        roi: (x, y, width, height) region of the scan to render, scan
            pixels (or "x,y,w,h"). Default: the whole scan.
        engine: "auto", "exact" or "fast".
        tolerance: density error budget of the approximate paths, (0, 1].
        tile: work tile side, scan pixels, [1, 4096] (speed only).
        output: what the returned array holds, as the CLI's ``output=``:
            "density" (the default: negative density per layer), "adx10" /
            "adx16" (Academy Density Exchange code values / 1023 or /
            65535, R, G, B), or "regrain" (a scene-linear positive in the
            config's scene_linear whose local mean is the input and whose
            fluctuation is the film's grain; needs the scan at the input's
            size). The transforms' warnings (e.g. clamped ADX code values)
            are Python UserWarnings. ADX is the stock's Academy Printing
            Density above D-min with ADX's gains (MODEL.md 11).
        timing: output="adx10" / "adx16" only (as the CLI's ``timing=``):
            "off" (the default: the standard encoding) or "grey" (printer
            lights that put the stock's own 18% grey on CDD 0.70, ACES
            0.18, in every channel).
        ocolorspace: output="regrain" only (as the CLI's --ocolorspace):
            the colour space of the positive, a name the colour config
            knows. Default: its scene_linear.
        colorconfig: the OCIO config file for output= (as the CLI's
            --colorconfig). Default: $OCIO, else the embedded config.
        threads: worker threads, int in [0, 4096]; 0: OpenImageIO's
            default (all hardware threads unless changed). Never changes
            the output.
        progress: optional callable(fraction in [0, 1]) called about ten
            times a second from the calling thread (with the GIL); a false
            return value other than None (e.g. False) cancels the render
            (filmgrain.Error "render cancelled"); an exception it raises
            cancels the render and propagates.
        **expert: the CLI's expert modifiers (kinetics, photons, coverage,
            grains, scale, samples), passed as they are; unknown names raise
            filmgrain.Error listing the valid modifiers.

    Values: ints and floats are passed exactly (floats by repr, which reads
    back as the same double); strings are passed in the CLI's syntax and
    cannot contain ':'.

    Returns:
        A :class:`Negative`, which unpacks as ``density, stats``: density is
        a float32 array (roi height, roi width, layers), layer names in
        ``.channels`` (with ``output=`` other than density: that output's
        values, channels R, G, B); stats is the CLI's --stats document as a
        dict.

    Raises:
        filmgrain.Error (a ValueError): any setting, stock or region the
            simulator refuses, with the core's message; "render cancelled".
        TypeError: pixels not a float32 numpy array, a value of the wrong
            Python type.
        KeyboardInterrupt: Ctrl-C during the render (which stops).
    """
    modifiers = dict(
        exposure_stops=exposure_stops,
        shutter_s=shutter_s,
        seed=seed,
        frame=frame,
        static_grain=static_grain,
        edge=edge,
        width_mm=width_mm,
        scan=scan,
        roi=roi,
        engine=engine,
        tolerance=tolerance,
        tile=tile,
        output=output,
        timing=timing,
    )
    modifiers.update(expert)
    return _render(pixels, stock, modifiers, threads, progress, None,
                   ocolorspace=ocolorspace, colorconfig=colorconfig)


def _optional_text(name, value):
    """None, or a non-empty str / os.PathLike as str."""
    if value is None:
        return None
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if not isinstance(value, str) or not value:
        raise TypeError(f"{name}={value!r}: expected a non-empty str")
    return value


def _render(pixels, stock_value, modifiers, threads, progress, window, ocolorspace=None,
            colorconfig=None):
    image = _as_image(pixels)
    if isinstance(threads, bool) or not isinstance(threads, numbers.Integral):
        raise TypeError(f"threads={threads!r}: expected an int in [0, 4096]")
    if progress is not None and not callable(progress):
        raise TypeError(f"progress={progress!r}: expected a callable or None")
    stock_name = stock_text = None
    if isinstance(stock_value, dict):
        try:
            stock_text = json.dumps(stock_value, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise TypeError(f"stock dict cannot be written as JSON: {e}") from None
    elif stock_value is not None:
        stock_name = _stock_name(stock_value)
    density, stats_text, attributes, region, channels = _filmgrain.render(
        image,
        _modifier_string(modifiers),
        stock_name,
        stock_text,
        int(threads),
        progress,
        window,
        _optional_text("ocolorspace", ocolorspace),
        _optional_text("colorconfig", colorconfig),
    )
    x, y, w, h, scan_w, scan_h = region
    return Negative(
        density, json.loads(stats_text), channels, attributes, (x, y, w, h), (scan_w, scan_h)
    )


def render_imagebuf(buf, *, stock=None, threads=0, progress=None, ocolorspace=None,
                    colorconfig=None, **modifiers):
    """:func:`render` for an OpenImageIO ImageBuf; returns (ImageBuf, stats).

    The pixels go through NumPy (``buf.get_pixels(OpenImageIO.FLOAT)``), so
    any OpenImageIO version with NumPy support works; no binding to OIIO's
    Python types is involved. buf must be scene-linear (convert first, e.g.
    with ``OpenImageIO.ImageBufAlgo.colorconvert``); its display window is
    the film frame and its data window is placed in it, as the C++
    operator ``filmgrain::IBA::filmgrain`` does (beyond the data window the
    scene continues, or with ``edge="gate"`` there is no light); the
    negative covers the data window. Keywords as for :func:`render`.

    Returns: (ImageBuf, stats): a float ImageBuf with one channel per stock
    layer, named after the layer, its display window the whole scan and its
    data window the roi, carrying the same ``filmgrain:*`` metadata as the
    CLI's EXR (write it with ``result.write("out.exr")``); stats as for
    :func:`render`. Raises as :func:`render`; also filmgrain.Error when buf
    has an error or is not a 2D image.
    """
    import OpenImageIO as oiio

    if buf.has_error:
        raise Error(f"the source ImageBuf has an error: {buf.geterror()}")
    spec = buf.spec()
    if spec.width < 1 or spec.height < 1 or spec.nchannels < 1:
        raise Error("the source ImageBuf is empty (no pixels or no channels)")
    if spec.depth > 1:
        raise Error(f"the source ImageBuf is a {spec.depth}-deep volume: expected a 2D image")
    pixels = buf.get_pixels(oiio.FLOAT)
    if pixels is None or buf.has_error:
        raise Error(f"cannot read the source ImageBuf's pixels: {buf.geterror()}")
    pixels = np.asarray(pixels, dtype=np.float32).reshape(
        spec.height, spec.width, spec.nchannels
    )
    window = (spec.x, spec.y, spec.full_x, spec.full_y, spec.full_width, spec.full_height)
    negative = _render(pixels, stock, modifiers, threads, progress, window,
                       ocolorspace=ocolorspace, colorconfig=colorconfig)
    return to_imagebuf(negative), negative.stats


def to_imagebuf(negative):
    """A :class:`Negative` as an OpenImageIO ImageBuf, as the CLI writes it.

    Float pixels, channels named after the stock's layers, display window
    the whole scan, data window the rendered region, and the operator's
    ``filmgrain:*`` metadata. Needs OpenImageIO's Python module (Debian:
    python3-openimageio).
    """
    import OpenImageIO as oiio

    h, w, nlayers = negative.density.shape
    spec = oiio.ImageSpec(w, h, nlayers, oiio.FLOAT)
    spec.x, spec.y = negative.roi[0], negative.roi[1]
    spec.full_x, spec.full_y = 0, 0
    spec.full_width, spec.full_height = negative.scan
    spec.channelnames = negative.channels
    for name, value in negative.attributes.items():
        spec.attribute(name, value)
    buf = oiio.ImageBuf(spec)
    if not buf.set_pixels(buf.roi, negative.density):
        raise Error(f"cannot store the density in an ImageBuf: {buf.geterror()}")
    return buf


def _modifier_reference():
    """The CLI's --filmgrain modifier table, for render()'s docstring."""
    lines = ["", "    CLI modifier reference (from the filmgrain CLI's own table):", ""]
    for key, form, help_text, default in _filmgrain.modifier_docs():
        lines.append(f"        {key}={form}: {help_text}. Default: {default}.")
    return "\n".join(lines) + "\n"


if render.__doc__:
    render.__doc__ += _modifier_reference()
