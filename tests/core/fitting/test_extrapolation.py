"""``core.fitting.extrapolation``: held-out rows whose inputs the fitted rows never reach."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.csvio import read_csv
from core.fitting import fit_recordings
from core.fitting.extrapolation import EXTRAPOLATION_MARGIN, extrapolation

AMORPHOUS = (Path(__file__).resolve().parents[3] / "examples" / "data" / "bh_loops"
             / "amorphous_alloy.csv")


def _ramp(n: int = 100) -> tuple[np.ndarray, np.ndarray]:
    return np.arange(n, dtype=float), np.linspace(-1.0, 1.0, n)


def test_held_out_rows_beyond_the_fitted_inputs_are_found() -> None:
    t, u = _ramp()
    fitted, held = t < 80, t >= 80  # fitted on -1 .. 0.6, held out 0.62 .. 1
    got = extrapolation([u], [t], [fitted], [held], ["ramp"], [False])
    assert got is not None
    (b,) = got.beyond
    assert b.recording == "ramp" and not b.timed and b.share == 1.0
    assert np.isclose(got.fitted[1], u[79]) and np.isclose(b.inputs[1], 1.0)
    assert (b.rows[0], b.rows[1]) == (80.0, 99.0)
    text = got.text({"input": "A/m"})
    assert "extrapolate" in text and "ramp" in text and "samples 80 to 99" in text
    assert "A/m" in text and "--test" in text and "no time axis" in text


def test_held_out_rows_inside_the_fitted_inputs_or_just_beyond_are_not() -> None:
    t, u = _ramp()
    u = np.sin(2 * np.pi * t / 25)  # four periods: the last one inside the first three
    assert extrapolation([u], [t], [t < 75], [t >= 75]) is None
    # beyond by less than the margin (held-out up to 1 + 0.5 margin of a range of 2)
    v = np.where(t >= 75, u * (1 + EXTRAPOLATION_MARGIN * 0.5), u)
    assert extrapolation([v], [t], [t < 75], [t >= 75]) is None


def test_the_amorphous_loop_fit_says_its_held_out_rows_extrapolate() -> None:
    """One B-H loop from its peak field, without its last 8 samples (no longer a closed loop,
    so its memory at the first sample is unknown): the rows until the input first reached
    both ends are left out of the fit, so the rows fitted run -800 to ~90 A/m and the
    held-out last fifth (the rising branch from ~100 A/m, samples 251-313) lies beyond. The
    whole loop is a closed loop in steady state: every row is fitted from the memory its
    cycle leaves, and nothing extrapolates."""
    import dataclasses

    (whole,) = read_csv(AMORPHOUS)
    assert not [w for w in fit_recordings(whole, "auto").warnings if "extrapolate" in w]
    rec = dataclasses.replace(whole, t=whole.t[:-8], u=whole.u[:-8], y=whole.y[:-8],
                              extra={}, extra_units={}, lines=None)
    out = fit_recordings(rec, "auto")
    (said,) = [w for w in out.warnings if "extrapolate" in w]
    assert "amorphous_alloy" in said and "to 720 A/m" in said
    assert "samples 251 to 313" in said and "--initial-memory keep" in said
    # no time axis: windows are said in samples, never in seconds
    assert not any("t = " in w for w in out.warnings)
    (miss,) = [w for w in out.warnings if "white-noise floor" in w]
    assert "(counted from 0; no time axis)" in miss
