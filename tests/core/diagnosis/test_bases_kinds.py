"""Each base kind of a diagnosis is declared once (:data:`core.diagnosis.bases.BASE_KINDS`),
and every name the report and the base choice give a base comes from that declaration."""

from __future__ import annotations

from core.diagnosis.bases import (
    BASE_KINDS,
    bouc_wen_elements,
    menegotto_pinto_elements,
    stop_stage,
)
from core.diagnosis.misspecification import describe_alternative, long_name
from core.diagnosis.results import BaseChoice, BaseRival, BaseTrial, StopBase
from core.diagnosis.structure import Structure
from core.stop import StopPIModel


def test_every_kind_a_structure_has_is_declared() -> None:
    """The kinds :attr:`Structure.base_kind` gives (PI, Preisach levels, a Bouc-Wen and a
    Menegotto-Pinto element bank, a stop base's input map) are the declared kinds, no more,
    no fewer, each under its own name."""
    s = Structure((0.1, 0.2), ((),))
    stop = StopPIModel(0.1, [0.05, 0.15], [1.0, 0.5], gap=0.08)
    kinds = [s, s.with_(levels=(0.5,)), s.with_(bouc_wen=bouc_wen_elements(1.0)),
             s.with_(bouc_wen=menegotto_pinto_elements(1.0, 1.0)),
             s.with_(shape=(stop_stage(stop),))]
    assert sorted(k.base_kind for k in kinds) == sorted(BASE_KINDS)
    assert all(name == k.name for name, k in BASE_KINDS.items())


def test_the_report_and_the_base_choice_name_bases_by_the_declaration() -> None:
    assert long_name("stop-pi") == BASE_KINDS["stop-pi"].long
    assert describe_alternative("menegotto-pinto", "pi") == \
        f"a {BASE_KINDS['menegotto-pinto'].long} base"
    assert long_name("no-such-base") == "no-such-base"
    row = BaseTrial("pi + saturation", 25, 1, 0.0, 0.9, BaseRival("menegotto-pinto", -0.5))
    choice = BaseChoice("pi", (row,), 4)
    assert f"the {BASE_KINDS['menegotto-pinto'].short} +50 % against it" in choice.text


def test_the_rows_json_form_keeps_its_keys() -> None:
    """A row's and a stop base's JSON form (``hyst diagnose --json``) are the objects the
    base choice always wrote: the rival's gain under ``"<rival>_mse_reduction_over_it"``,
    with output dynamics the same key ``..._with_dynamics``; the stop base's falling
    plateau the plateau times the ratio."""
    row = BaseTrial("pi + asymmetry", 25, 1, 0.0, 0.5,
                    BaseRival("menegotto-pinto", 0.1, 0.05))
    assert row.to_dict() == {"base": "pi + asymmetry", "operators": 25, "level_segments": 1,
                             "smoothness": 0.0, "cv_mse_reduction": 0.5,
                             "menegotto_pinto_mse_reduction_over_it": 0.1,
                             "menegotto_pinto_mse_reduction_over_it_with_dynamics": 0.05}
    assert BaseTrial("bouc-wen", 16, 1, 0.0, 0.2, cv_mse_reduction_with_dynamics=0.3
                     ).to_dict()["cv_mse_reduction_with_dynamics"] == 0.3
    st = StopBase(0.1, 25, 2.0, 0.4, True, 1.5)
    assert st.to_dict() == {"gap": 0.1, "elements": 25, "friction_plateau": 2.0,
                            "heldout_mse_reduction": 0.4, "chosen": True,
                            "slip_force_ratio": 1.5, "friction_plateau_falling": 3.0}
    assert "3 output units where it is negative" in st.plateau_words()
