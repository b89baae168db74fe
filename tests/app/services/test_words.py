"""Internal names in words (issue 33, item 2): every registered type has words without a
name of the code in them; sentences written elsewhere get their names replaced; the
diagnosis's findings and its plot give one "after" error."""

from __future__ import annotations

import re

import numpy as np

from app.services.analysis.diagnosis import diagnosis_summary
from app.services.explore import figures as F
from app.services.words import (
    diagnosed_words,
    field_words,
    in_words,
    internal_names,
    model_words,
    type_words,
    unit_words,
)
from core.models import fit_kinds, model_types
from core.recordings import Recording


def _leaks(text: str) -> list[str]:
    return [n for n in internal_names()
            if re.search(rf"(?<![\w\-.]){re.escape(n)}(?![\w\-])", text)]


def test_every_type_has_words_without_code_names() -> None:
    for t in model_types():
        words = type_words(t.name)
        assert words and words == type_words(t.cls.__name__), t.name
        assert not _leaks(words), (t.name, words)
        assert "``" not in words and ":class:" not in words, words
    assert type_words("gpi-deadzone") == "Dead-zone GPI"
    assert type_words("pi") == "Classical PI model"
    assert type_words("DeadZoneGPI") == "Dead-zone GPI"
    assert len({type_words(k) for k in fit_kinds()}) == len(fit_kinds())  # a menu tells apart


def test_the_names_of_the_code_are_the_registrys() -> None:
    names = set(internal_names())
    assert {"gpi-deadzone", "pi", "PIModel", "DeadZoneGPI", "initial-memory", "state0",
            "delay_s", "preisach"} <= names
    # plain words and the sliders' own labels are not
    assert not {"delay", "lag", "creep", "drift", "offset", "p0", "Lag", "tanh-envelope"} & names


def test_sentences_get_words() -> None:
    text = in_words("fitting initial-memory; (preisach 0.21 %, gpi-deadzone 0.84 %, mpi 1.58 %)"
                    "; a pi model; Tried: delay, lag")
    assert not _leaks(text), text
    assert "Dead-zone GPI 0.84 %" in text and "Preisach model 0.21 %" in text
    assert "a classical PI model;" in text and "Tried: delay, lag" in text
    assert in_words("PIModel, n = 6") == "Classical PI model, n = 6"
    # a title's capital only where a sentence or an item starts (issue 33: "fitting
    # Initial memory" in the diagnosis's progress); names and abbreviations keep theirs
    assert text.startswith("fitting initial memory;"), text
    assert in_words("fitting mpi") == "fitting Kuhnen's modified PI"
    assert in_words("fitting stop-pi") == "fitting stop-operator Prandtl model"
    assert in_words("initial-memory: 2 %") == "Initial memory: 2 %"


def test_fields_and_units_in_words() -> None:
    assert field_words("initial-memory", "history") == "Input history u_k"
    assert field_words("pi", "nothing_here") == "nothing here"
    assert unit_words("um") == "µm" and unit_words(None) == ""
    from app.services.explore.simulation import preset_doc
    from core.base import model_from_dict
    assert model_words(model_from_dict(preset_doc("paper001-example4")["model"])) == \
        "Dead-zone GPI"


def test_a_diagnosed_chain_is_said_as_what_was_diagnosed() -> None:
    """The piezo's diagnosed model (initial memory and asymmetry on a classical PI) is said
    stage by stage in the words of the findings ("Found initial memory", "Found asymmetry"),
    each stage once, the wrapped PI model with it."""
    from core.base import Chain
    from core.pi import PIModel
    from core.stages.maps import Asymmetry, Offset
    from core.stages.memory import InitialMemory

    pi = PIModel.from_dict({"type": "pi", "p0": 1.0, "thresholds": [0.5, 1.0],
                            "weights": [0.3, 0.2]})
    chain = Chain((InitialMemory(model=pi, history=np.array([-1.0, 0.5])),
                   Asymmetry(coefficients=np.array([0.05, -0.9]), center=0.0, scale=20.0),
                   Offset(offset=0.1)))
    words = model_words(chain)
    assert words == "Classical PI model with initial memory → Output asymmetry → " \
        "Constant output offset", words
    assert not _leaks(words) and "GPI" not in words
    # the status line of the diagnosis view names only what the findings name: the
    # baseline's own bias (no finding "offset") is left out (issue 33)
    assert diagnosed_words(chain, ["initial-memory", "asymmetry"]) == \
        "Classical PI model with initial memory → Output asymmetry"
    assert diagnosed_words(chain, ["initial-memory", "asymmetry", "offset"]) == words
    assert diagnosed_words(pi, []) == "Classical PI model"


def _doc(effects: list[dict]) -> dict:
    return {"baseline": {"heldout_rmse": 0.767, "heldout_rmse_pct": 1.95},
            "final": {"heldout_rmse": 0.102, "heldout_rmse_pct": 0.26,
                      "effects": [e["name"] for e in effects]},
            "effects": effects,
            "adequacy": {"adequate": False, "text": "misses 0.26 % (RMS 0.1023, 2.1 times the "
                         "white-noise floor 0.0476); Tried: initial-memory. (gpi-deadzone "
                         "0.84 %)"}}


def test_one_after_number_in_the_findings() -> None:
    one = [{"name": "initial-memory", "heldout_rmse_before": 0.767, "heldout_rmse_after": 0.119,
            "parameters": {"history": [[-123.0]]}}]
    found = diagnosis_summary(_doc(one), {"input": "V", "output": "um"}).findings
    text = "\n".join(found)
    assert "by 0.102 µm (0.26 %)" in found[0]
    assert "from 0.767 µm to 0.102 µm RMS" in found[1] and "0.119" not in text
    assert "Fitted: Input history u_k = -123 V." in found[1]  # was "histo = -123 V"
    assert "RMS 0.102 µm" in text and "floor 0.0476 µm" in text
    assert not _leaks(text), _leaks(text)
    two = one + [{"name": "asymmetry", "heldout_rmse_before": 0.119,
                  "heldout_rmse_after": 0.0595, "parameters": {}}]
    found = diagnosis_summary(_doc(two), {"output": "um"}).findings
    # the rounds' own "after" errors are not shown: each effect's share in percent
    assert re.findall(r"(?:\bto|added, by) ([\d.]+) µm", "\n".join(found)) == ["0.102"]
    assert "lowers the held-out error by 84 %" in found[1]
    assert "lowers the held-out error by 50 %" in found[2]


def test_the_diagnosis_plot_title_gives_the_findings_numbers() -> None:
    t = np.arange(200) * 0.01
    u = np.sin(2 * np.pi * t)
    rec = Recording(t=t, u=u, y=u + 0.3, name="r", units={"output": "um"})
    fig = F.diagnosis_figure(rec, u, u + 0.25, "PI model", "with offset",
                             heldout=(0.767, 0.102))
    title = fig.layout["title"]["text"]
    assert title.endswith("(held-out RMS 0.767 → 0.102 µm)"), title
    assert [d["name"] for d in fig.data][3:] == ["residual before", "residual after"]


#: One fitted parameter document per registered effect (the keys its ``build`` returns).
FITTED = {
    "asymmetry": {"a2": 0.12, "a3": -0.05, "center": 1.3, "scale": 2.1},
    "creep": {"gamma_per_decade": 0.01, "taus_s": [0.1, 1.0, 10.0], "weights": [0.1, 0.2]},
    "dead-zone": {"side": "both", "thresholds": [0.0, 1.0], "weights": [1.0, 0.2],
                  "breakpoints": [0.1], "relative_slopes": [0.2, 1.0], "dead_band": "x"},
    "delay": {"delay_s": 0.001},
    "drift": {"coefficients": [[0.1, 0.2]], "peak_to_peak": [0.3]},
    "initial-memory": {"history": [[1.0, -2.0]]},
    "lag": {"tau_s": 0.002},
    "offset": {"offsets": [0.1]},
    "rate": {"beta_s": 0.01},
    "resonance": {"freq_hz": 500.0, "damping": 0.05},
    "saturation": {"a1": 0.5, "a2": 0.1, "center": 1.0, "half_slope_below": -1.0,
                   "half_slope_above": 3.0, "slope_at_input_min": 0.3,
                   "slope_at_input_max": 0.2, "saturation": "s"},
}


def test_every_effects_fitted_values_in_words() -> None:
    """The fitted values in the findings (issue 33, item 2): no parameter is named by its
    symbol in the code (asymmetry's ``a2``, ``a3`` were, being no field of a registered
    type, so the scan of internal names missed them), and each value has its unit."""
    from core.diagnosis.registry import EFFECTS

    assert set(FITTED) == set(EFFECTS)  # a new effect gets its row here
    for name, params in FITTED.items():
        e = {"name": name, "heldout_rmse_before": 0.8, "heldout_rmse_after": 0.1,
             "parameters": params}
        text = diagnosis_summary(_doc([e]), {"input": "V", "output": "um"}).findings[1]
        symbols = [k for k in params if re.search(r"[_\d]", k)
                   and re.search(rf"(?<![\w\-.]){re.escape(k)}(?![\w\-])", text)]
        assert symbols == [] and not _leaks(text), (name, symbols, _leaks(text), text)
    text = diagnosis_summary(_doc([{"name": "asymmetry", "parameters": FITTED["asymmetry"]}]),
                             {"input": "V", "output": "um"}).findings[1]
    assert "output added at both ends of the loop (its bend) = 0.12 µm" in text, text
    assert "taken at the lower (its stretch) = -0.05 µm" in text, text
    assert "half-range (from the centre to either end) = 2.1 µm" in text, text
    text = diagnosis_summary(_doc([{"name": "resonance", "parameters": FITTED["resonance"]}]),
                             {"input": "V", "output": "um"}).findings[1]
    assert "natural frequency = 500 Hz" in text, text


def test_the_command_lines_report_says_the_fitted_values_in_words() -> None:
    """``hyst diagnose`` without ``--json``: the asymmetry's fitted values in words and
    the recording's units, as on the pages (``core.diagnosis.report``)."""
    from types import SimpleNamespace

    from core.diagnosis.report import _param_text

    e = SimpleNamespace(name="asymmetry", uncertainty={"a2": 0.01}, ambiguous_parameters=())
    assert _param_text(e, "a2", 0.12, {"output": "um"}) == \
        "output added at both ends of the loop (its bend) = 0.12 ± 0.01 um"
    assert _param_text(e, "a3", -0.05, {}) == ("output added at the upper end and taken at "
                                               "the lower (its stretch) = -0.05 output units")
    lag = SimpleNamespace(name="lag", uncertainty={}, ambiguous_parameters=())
    assert _param_text(lag, "tau_s", 0.002, {}) == "tau_s = 0.002"


def test_where_an_effect_acts_is_in_samples_without_a_time_axis_and_names_the_run() -> None:
    """A diagnosis of a file's runs without a time column: the stretches where an effect
    acts are sample numbers of a named run, not seconds (before: '12–40 s'); with a time
    axis and one recording, seconds and no name. The base is named by its kind."""
    where = {"time_windows": [["loop=1", 12.0, 40.0, 0.5]], "input_range": [-2.0, 3.0],
             "median_since_reversal_s": 7.0}
    e = [{"name": "saturation", "heldout_rmse_before": 0.767, "heldout_rmse_after": 0.102,
          "parameters": {}, "where": where}]
    runs = [{"name": "loop=0", "time_axis": False}, {"name": "loop=1", "time_axis": False}]
    doc = {**_doc(e), "recordings": runs,
           "baseline": {**_doc(e)["baseline"], "model": "menegotto-pinto"}}
    text = "\n".join(diagnosis_summary(doc, {"input": "A/m", "output": "T"}).findings)
    assert "loop=1 samples 12–40" in text and "7 samples after the input turned" in text
    assert " s " not in text.replace("samples", "")
    assert "the Menegotto-Pinto model" in text
    doc = {**_doc(e), "recordings": [{"name": "r", "time_axis": True}]}
    text = "\n".join(diagnosis_summary(doc, {"input": "V", "output": "um"}).findings)
    assert "12–40 s" in text and "r 12" not in text and "7 s after" in text


def test_effects_untestable_for_one_reason_are_said_once() -> None:
    """A file without a time axis: six time effects untestable for the same reason are one
    sentence naming them all (before: six sentences with the same reason); an effect with
    its own reason keeps its own."""
    why, need = "the runs have no time axis", "the same recording with its time stamps"
    untestable = [{"name": n, "reason": why, "experiment": need}
                  for n in ("delay", "lag", "resonance")]
    untestable.append({"name": "offset", "reason": "one recording", "experiment": "several"})
    found = diagnosis_summary({**_doc([]), "untestable": untestable}).findings
    said = [f for f in found if "cannot be tested" in f]
    assert len(said) == 2, said
    assert said[0].count(why) == 1 and " and " in said[0].split("cannot")[0]
    assert "one recording" in said[1]
