"""Shared helpers for the example scripts: quick mode and self-contained HTML output.

Every example runs as ``python examples/exNN_name.py [--out DIR]``. With ``HYST_QUICK=1``
(the tests set it) examples use short signals so they finish in a second or two.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def quick() -> bool:
    """True when ``HYST_QUICK=1``: use short signals, skip slow parts."""
    return os.environ.get("HYST_QUICK", "") == "1"


def parse_out(description: str) -> Path:
    """Parse ``--out DIR`` (default ``$HYST_EXAMPLES_OUT`` or ``out/examples``) and create it."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument(
        "--out",
        type=Path,
        default=Path(os.environ.get("HYST_EXAMPLES_OUT", ROOT / "out" / "examples")),
        help="folder for the HTML figures (default: out/examples)",
    )
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    return args.out


def save(fig, out: Path, name: str) -> Path:  # fig: plotly.graph_objects.Figure
    """Write ``fig`` as self-contained HTML (plotly.js inlined, no CDN) and return its path."""
    path = out / f"{name}.html"
    fig.write_html(path, include_plotlyjs=True, full_html=True)
    # The inlined plotly.js names a CDN folder for map topology data (unused by our
    # figures); point it at a local folder so the page never refers to the network.
    text = path.read_text(encoding="utf-8")
    path.write_text(text.replace('"https://cdn.plot.ly/un/"', '"topojson/"'), encoding="utf-8")
    print(f"wrote {path}")
    return path
