"""``hyst fit`` on long recordings (issue 31): refused up front, in words, when its measured
model (app.services.runs.cost.FIT) needs more memory than there is."""

from __future__ import annotations

import numpy as np

from app.cli import main
from app.commands import _scale
from app.services.runs.cost import FIT


def test_hyst_fit_refuses_up_front_what_cannot_fit(tmp_path, monkeypatch, capsys):
    t = np.arange(3000) * 1e-3
    src = tmp_path / "long.csv"
    src.write_text("t,u,y\n" + "".join(f"{a:.3f},{np.sin(9 * a):.6f},{np.cos(9 * a):.6f}\n"
                                        for a in t), encoding="utf-8")
    monkeypatch.setattr(_scale, "allowed_memory", lambda: int(FIT.peak_bytes(1000)))
    assert main(["fit", str(src), "-o", str(tmp_path / "m.json"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "hyst fit: error:" in err and "3,001 samples; fitting it would need about" in err
    assert "at most about 1,000 samples here" in err
    assert not (tmp_path / "m.json").exists()
