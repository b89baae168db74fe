"""Each base kind of a diagnosis is declared once (:data:`core.diagnosis.bases.BASE_KINDS`),
and every name the report gives a base comes from that declaration."""

from __future__ import annotations

from core.diagnosis.bases import (
    BASE_KINDS,
    bouc_wen_elements,
    menegotto_pinto_elements,
    stop_stage,
)
from core.diagnosis.misspecification import describe_alternative, long_name
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


def test_the_report_names_bases_by_the_declaration() -> None:
    assert long_name("stop-pi") == BASE_KINDS["stop-pi"].long
    assert describe_alternative("menegotto-pinto", "pi") == \
        f"a {BASE_KINDS['menegotto-pinto'].long} base"
    assert long_name("no-such-base") == "no-such-base"
