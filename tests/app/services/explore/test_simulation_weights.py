"""A negative play weight explained (issue 33, item 6): what it does to the slopes (the
cumulative sums p0 + p1 + ..., paper 001 eq. 33) and to invertibility."""

from __future__ import annotations

from app.services.explore.simulation import weight_note
from core.base import Chain
from core.deadzone import DeadZoneMap
from core.pi import PIModel


def test_no_note_without_a_negative_weight() -> None:
    assert weight_note(PIModel(0.72, [0.45, 0.9], [0.6, 0.48])) is None


def test_a_negative_weight_that_keeps_every_slope_positive() -> None:
    m = PIModel(0.72, [0.45, 0.9, 1.35], [0.6, -0.3, 0.2])
    note = weight_note(m)
    assert m.is_invertible and note is not None
    # slopes 0.72, 1.32, 1.02, 1.22 (by hand): min 0.72, max 1.32
    assert note.startswith("Negative weight p2 = -0.3: ")
    assert "slopes 0.72 to 1.32" in note and "stays invertible" in note


def test_a_negative_weight_that_leaves_no_inverse() -> None:
    m = PIModel(0.72, [0.45, 0.9, 1.35], [0.6, -1.5, 0.2])
    note = weight_note(m)  # slopes 0.72, 1.32, -0.18, 0.02
    assert not m.is_invertible and note is not None
    assert "-0.18" in note and "no inverse" in note


def test_the_pi_inside_a_chain_is_read() -> None:
    pi = PIModel(1.0, [0.5, 1.0], [-0.2, 0.1])
    dz = DeadZoneMap([0.0, 0.5], [1.0, 0.2])
    assert "p1 = -0.2" in (weight_note(Chain.of(dz, pi)) or "")
