"""Where an improvement lies (:func:`core.diagnosis.locate.where_improved`), said in the
recording's own time: seconds with a time axis, sample numbers without one (B-H loops)."""

from __future__ import annotations

import numpy as np

from core.diagnosis.locate import coordinates, where_improved
from core.recordings import Recording


def _rec(has_time: bool) -> Recording:
    n = 400
    t = np.arange(n) * (1e-3 if has_time else 1.0)
    u = np.sin(2 * np.pi * np.arange(n) / 100)
    return Recording(t=t, u=u, y=u, has_time=has_time, name="r")


def test_an_improvement_is_placed_in_seconds_or_in_samples() -> None:
    for has_time in (True, False):
        rec = _rec(has_time)
        before = np.where(np.arange(rec.n_samples) < 40, 1.0, 0.01)  # the error sits early
        after = np.full(rec.n_samples, 0.01)
        w = where_improved([rec], [before], [after], coordinates([rec]))
        text = w["summary"]
        # the error reduction lies in the first 40 samples: 0-0.039 s, or samples 0-39
        if has_time:
            assert "r 0-0.0" in text and " s after a reversal" in text, text
            assert "samples" not in text, text
        else:
            assert "r samples 0-" in text and " samples after a reversal" in text, text
            assert " s," not in text and " s;" not in text, text
