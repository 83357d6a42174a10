"""The viewer's page packed small: plotly.js and the figure deflated and written as text.

plotly.js is 4.8 MB of JavaScript; deflated (zlib, level 9) it is 1.5 MB. The page carries it,
and the figure's JSON, as base-85 text in script elements the browser does not run
(``type="application/x-deflate-b85"``), and a short loader inflates them with the browser's own
``DecompressionStream``, runs plotly.js and draws the figure. The page stays one file that opens
from disk with no network, at about 1.9 MB.

The base-85 alphabet is Python's (:func:`base64.b85encode`, RFC 1924's) with ``<``, ``>`` and
``&`` written as ``.``, ``,`` and ``:``: no run of the text can open a tag or an entity inside the
script element.
"""

from __future__ import annotations

import base64
import functools
import html
import json
import re
import zlib
from pathlib import Path

import plotly

_SWAPS = str.maketrans("<>&", ".,:")
"""Python's base-85 characters that could open a tag or an entity, and what stands for them."""

_SWAPS_BACK = str.maketrans(".,:", "<>&")

_ALPHABET = (
    "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz!#$%&()*+-;<=>?@^_`{|}~"
).translate(_SWAPS)

_LOADER = """
(async () => {
  const alphabet = %(alphabet)s;
  const digits = new Uint8Array(128);
  for (let i = 0; i < 85; i++) digits[alphabet.charCodeAt(i)] = i;
  async function unpack(id) {
    const element = document.getElementById(id);
    const text = element.textContent.trim();
    const bytes = new Uint8Array(text.length / 5 * 4);
    for (let i = 0, o = 0; i < text.length; i += 5, o += 4) {
      let v = 0;
      for (let j = 0; j < 5; j++) v = v * 85 + digits[text.charCodeAt(i + j)];
      bytes[o] = v >>> 24; bytes[o + 1] = (v >>> 16) & 255;
      bytes[o + 2] = (v >>> 8) & 255; bytes[o + 3] = v & 255;
    }
    const deflated = bytes.subarray(0, Number(element.dataset.length));
    const stream = new Blob([deflated]).stream().pipeThrough(new DecompressionStream("deflate"));
    return new Response(stream).text();
  }
  const library = document.createElement("script");
  library.text = await unpack("plotly-js");
  document.head.appendChild(library);
  const figure = JSON.parse(await unpack("figure"));
  await Plotly.newPlot("plan", figure.data, figure.layout, %(config)s);
  if (figure.frames) await Plotly.addFrames("plan", figure.frames);
})();
"""


def _packed(data: bytes, element_id: str) -> str:
    """``data`` deflated, as a script element of base-85 text the browser does not run."""
    deflated = zlib.compress(data, 9)
    text = base64.b85encode(deflated, pad=True).decode("ascii").translate(_SWAPS)
    return (
        f'<script type="application/x-deflate-b85" id="{element_id}" '
        f'data-length="{len(deflated)}">{text}</script>'
    )


@functools.cache
def _plotly_js() -> str:
    """plotly.js as the page carries it (packed once a process)."""
    source = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
    return _packed(source.read_bytes(), "plotly-js")


def page(figure_json: str, config: dict[str, object], title: str, height_px: int) -> str:
    """The whole page: the plot's element, plotly.js and the figure packed, and the loader.

    Parameters
    ----------
    figure_json
        The figure as plotly's JSON (``data``, ``layout`` and ``frames``).
    config
        plotly.js's configuration of the plot (buttons, responsiveness).
    title
        The page's title.
    height_px
        The plot element's height.
    """
    loader = _LOADER % {"alphabet": json.dumps(_ALPHABET), "config": json.dumps(config)}
    return (
        '<!DOCTYPE html>\n<html>\n<head>\n<meta charset="utf-8">\n'
        f"<title>{html.escape(title)}</title>\n</head>\n<body>\n"
        f'<div id="plan" style="height:{height_px}px; width:100%;"></div>\n'
        f"{_plotly_js()}\n{_packed(figure_json.encode('utf-8'), 'figure')}\n"
        f"<script>{loader}</script>\n</body>\n</html>\n"
    )


def unpacked(page_text: str, element_id: str) -> bytes:
    """What the script element ``element_id`` of a packed page carries (for checks)."""
    found = re.search(rf'id="{element_id}" data-length="(\d+)">([^<]*)</script>', page_text)
    if found is None:
        raise ValueError(f"no packed script {element_id!r} in the page")
    length, text = int(found.group(1)), found.group(2)
    deflated = base64.b85decode(text.translate(_SWAPS_BACK))[:length]
    return zlib.decompress(deflated)
