"""The published characteristic curves of a fitted stock through printing
density (MODEL.md 11): the datasheet the stock was fitted to
(stocks/datasheets, found by its name: filmgrain-fit names a stock after its
datasheet), its Status M curves read at given exposures, above its D-min,
through its Annex C map to Academy Printing Density, times ADX's gains. That
is the CDD a fit that met its datasheet exactly would encode.

Used by tools/look/look_pictures.py (what keeps the wedge's preview from
neutral) and tests/cli/test_adx.py (the published curves meet issue 40's
targets).
"""
import json
from pathlib import Path

import numpy as np

DATASHEETS = Path(__file__).resolve().parents[2] / "stocks" / "datasheets"


def datasheet(stock):
    """(file name, parsed JSON) of the datasheet named `stock`, or None."""
    for path in sorted(DATASHEETS.glob("*.json")):
        sheet = json.loads(path.read_text())
        if sheet.get("name") == stock:
            return path.name, sheet
    return None


def published_cdd(sheet, log_h, gains):
    """(n, 3) CDD of the sheet's R, G, B curves at the n exposures `log_h`
    (log10 lux-seconds): gains x (APD - APD at D-min), the APD from the
    sheet's printing_density map (its offset cancels in the difference)."""
    layers = {layer["name"]: layer for layer in sheet["layers"]}
    m = np.array(sheet["printing_density"]["status_m_to_apd"]["matrix"])
    d = np.array([[np.interp(x, layers[c]["curve"]["log_h"], layers[c]["curve"]["density"])
                   for c in "RGB"] for x in np.atleast_1d(log_h)])
    d_min = np.array([layers[c]["d_min"] for c in "RGB"])
    return np.asarray(gains) * ((d - d_min) @ m.T)
