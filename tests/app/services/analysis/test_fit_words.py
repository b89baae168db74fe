"""A fit in the page's words: the command line's options and commands become the page's
controls, model type names become their words, and the held-out error is the report's."""

from __future__ import annotations

import re

import numpy as np

from app.services.analysis.fit_words import fit_words, page_words
from app.services.words import internal_names


def _leaks(text: str) -> list[str]:
    return [n for n in internal_names()
            if re.search(rf"(?<![\w\-.]){re.escape(n)}(?![\w\-])", text)]


def test_command_line_words_become_the_page_s() -> None:
    text = ("No other base tried predicted better; hyst diagnose may name the missing "
            "effect. Another fit kind (--model auto chooses one), or fit --model stop-pi, "
            "or --model bouc-wen; choose --train and --test windows; loop slope S1 sits on "
            "its lower bound min_slope = 1.6e-06: consider a larger min_slope")
    said = page_words(text)
    for word in ("--model", "--constraint", "hyst diagnose", "stop-pi", "bouc-wen",
                 "min_slope"):
        assert word not in said, (word, said)
    assert "Run diagnosis" in said and "fit menu" in said
    # the windows the page cannot choose: the command line's, said so
    assert "the command line's hyst fit and its --train and --test windows" in said
    assert _leaks(said) == [], said


def test_fit_words_give_the_report_s_held_out_error_and_choice() -> None:
    from core.fitting import fit_recordings
    from core.pi import PIModel
    from core.recordings import Recording

    t = np.arange(2000) * 1e-3
    u = 3 * np.sin(2 * np.pi * 3 * t) * (1 + t)
    y = PIModel(0.7, [0.5, 1.0], [0.5, 0.3])(u)
    rec = Recording(t=t, u=u, y=y + 1e-3 * np.random.default_rng(1).normal(size=t.size),
                    units={"time": "s", "input": "V", "output": "um"})
    out = fit_recordings(rec, "auto", n_operators=4)
    words = fit_words(out, "µm")
    assert "chosen automatically" in words.model and "4 operators" in words.model
    assert f"{out.report.test.rmse_pct:.3g} % of the range" in words.heldout
    assert words.choice is not None and _leaks(words.choice) == [], words.choice
    manual = fit_words(fit_recordings(rec, "pi", n_operators=4), "µm")
    assert manual.choice is None and "chosen automatically" not in manual.model
