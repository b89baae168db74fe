"""``Candidate.judged_as`` (acceptance rule 6): a candidate judged again on top of another
effect keeps what belongs to its own fit (parameters, their cross-fitted spread, its
predictions between recordings) and takes every field of the judgement that decided, so the
finding's evidence words (which rows, the numbers on the other rows, the waived share)
describe the comparison that decided and not the one on the model without the other."""

from __future__ import annotations

from dataclasses import fields

import pytest

from core.diagnosis.acceptance import Decision
from core.diagnosis.judge import choose
from core.diagnosis.specs import FAMILY_PRIORITY
from core.diagnosis.state import Candidate
from core.diagnosis.stats import HeldOut


def _held(gain: float, z: float) -> HeldOut:
    return HeldOut(mse_before=1.0, mse_after=1.0 - gain, gain=gain, z=z, sign_p=0.5,
                   n_batches=12)


def _decision(passes: bool) -> Decision:
    return Decision(passes=passes, size_ok=True, significant=passes, stable=True, reasons=())


def _pair() -> tuple[Candidate, Candidate]:
    alone = Candidate("drift", fit="fit on the model without creep", parameters={"a": 1.0},
                      uncertainty={"a": 0.1}, heldout=_held(0.04, 2.0), size_ok=False,
                      crossfit="folds of the fit without creep",
                      between="predictions of the fit without creep",
                      decision=_decision(False), verdict="deferred",
                      where="cycle to cycle (alone)",
                      elsewhere=_held(-0.03, -1.0))
    on_top = Candidate("drift", fit="fit on top of creep", parameters={"a": 2.0},
                       uncertainty={"a": 0.2}, heldout=_held(0.09, 4.0), size_ok=True,
                       crossfit="folds of the fit on top of creep",
                       between="predictions of the fit on top of creep",
                       share_waived=True, decision=_decision(True),
                       where="cycle to cycle (on top of creep)", elsewhere=_held(0.01, 0.4),
                       overall=_held(0.03, 1.5), beyond_history=True, noise_factor=2.0)
    return alone, on_top


def test_the_judgement_comes_from_the_comparison_that_decided() -> None:
    alone, on_top = _pair()
    c = alone.judged_as(on_top, given="creep")
    assert c.fit == alone.fit and c.parameters == alone.parameters
    assert c.uncertainty == alone.uncertainty
    assert c.crossfit == alone.crossfit and c.between == alone.between
    assert c.given == "creep"
    for f in ("heldout", "size_ok", "share_waived", "decision",
              "verdict", "where", "elsewhere", "overall", "beyond_history",
              "noise_factor"):
        assert getattr(c, f) == getattr(on_top, f), f


def test_every_field_is_either_fit_or_judgement() -> None:
    """A field added to ``Candidate`` later must be sorted into one of the two groups."""
    alone, on_top = _pair()
    c = alone.judged_as(on_top, given="creep")
    own = {"name", "fit", "parameters", "uncertainty", "crossfit", "between"}
    for f in fields(Candidate):
        if f.name in own:
            assert getattr(c, f.name) == getattr(alone, f.name), f.name
        elif f.name != "given":
            assert getattr(c, f.name) == getattr(on_top, f.name), f.name


def test_another_effects_judgement_is_refused() -> None:
    alone, on_top = _pair()
    with pytest.raises(ValueError, match="drift.*creep"):
        alone.judged_as(Candidate("creep", *(getattr(on_top, n) for n in
                                             ("fit", "parameters", "uncertainty", "heldout"))),
                        given="offset")


def test_families_are_chosen_between_on_all_the_test_rows() -> None:
    """A creep judged inside the holds (79 % of the MSE of the changes there) and a rate
    judged on every test row (60 %) both pass. Their shares are of different rows; on all
    the test rows the creep removes 95 %. Rate's family comes first and keeps its place
    unless the other explains 1.5 times as much: compared on the same rows, creep does."""
    creep = Candidate("creep", fit="creep", parameters={}, uncertainty={},
                      heldout=_held(0.79, 8.0), where="inside the holds",
                      overall=_held(0.95, 6.0))
    rate = Candidate("rate", fit="rate", parameters={}, uncertainty={}, heldout=_held(0.60, 2.5))
    assert creep.choice_gain == 0.95 and rate.choice_gain == 0.60
    assert FAMILY_PRIORITY[rate.family] < FAMILY_PRIORITY[creep.family]
    cands = {"creep": creep, "rate": rate}
    assert choose(list(cands), {n: c.choice_gain for n, c in cands.items()}) == "creep"
    # the shares of different rows would have kept the rate
    assert choose(list(cands), {n: c.heldout.gain for n, c in cands.items()}) == "rate"
