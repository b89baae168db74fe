"""The text report of a diagnosis (core.diagnosis.report): what was tested and not claimed,
read from the typed round rows."""

from __future__ import annotations

import dataclasses

from core.diagnosis.results import DiagnosisResult, suggestive_rows


def test_not_claimed_lines_from_the_typed_rows(weak_rate_set_diagnosis: DiagnosisResult
                                               ) -> None:
    """Four recordings at different rates: each suggestive row is a line with its statistics
    (the cross-fitted ones where the row has them, given to the lag's row here), and the
    effects judged between recordings only are said tested and not claimed."""
    res = weak_rate_set_diagnosis
    rows = suggestive_rows(res.rounds)
    assert [r.effect for r in rows] == ["delay", "lag", "rate"]
    assert res.suggestive_rows == rows
    res.rounds = [dataclasses.replace(r, extra=(*r.extra, ("dm_z_pooled", 1.234),
                                                ("signed_rank_p_pooled", 0.0412),
                                                ("parameter_cv", {"tau_s": 0.13})))
                  if r is rows[1] else r for r in res.rounds]
    text = res.summary()
    for r in rows:
        assert (f"Suggestive, not claimed: {r.effect} (held-out MSE "
                f"-{100 * r.heldout_mse_reduction:.0f} %, z = {r.dm_z:.2f}, "
                f"signed-rank p = {r.signed_rank_p:.2g}") in text
    lag = rows[1]
    assert (f"lag (held-out MSE -{100 * lag.heldout_mse_reduction:.0f} %, z = {lag.dm_z:.2f}, "
            f"signed-rank p = {lag.signed_rank_p:.2g}; with the cross-fitted blocks z = 1.23, "
            "p = 0.041, parameter CV across folds tau_s 13 %: below the acceptance rule)") in text
    between = [r.effect for r in res.rounds
               if r.round == 1 and "per_recording" in dict(r.extra)
               and r.effect not in {*(g.effect for g in rows), *(e.name for e in res.effects)}]
    assert between
    for name in between:
        assert f"Tested between recordings, not claimed: {name} (each recording" in text
