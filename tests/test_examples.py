"""Every example script runs end to end in quick mode and writes self-contained HTML."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted(p for p in (ROOT / "examples").glob("ex*.py"))


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs(script: Path, tmp_path: Path) -> None:
    env = {**os.environ, "HYST_QUICK": "1", "HYST_EXAMPLES_OUT": str(tmp_path),
           "PYTHONPATH": str(ROOT)}  # the checkout's code, not an installed copy
    proc = subprocess.run(
        [sys.executable, str(script), "--out", str(tmp_path)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-4000:]
    html = list(tmp_path.glob("*.html"))
    assert html, "example wrote no figure"
    for h in html:
        text = h.read_text(encoding="utf-8", errors="replace")
        assert "cdn.plot.ly" not in text, f"{h.name} uses a CDN"
        assert '<script src="http' not in text, f"{h.name} loads a remote script"
        assert "Plotly.newPlot" in text or "plotly" in text.lower()
