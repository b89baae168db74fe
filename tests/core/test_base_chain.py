"""The model algebra: Chain composition, inverse order, state, serialisation."""

from __future__ import annotations

import numpy as np
import pytest

from core.base import Chain, model_from_dict, registered_types
from core.exceptions import NotInvertibleError, ParameterError
from core.lti import LinearSystem
from core.pi import PIModel

A = PIModel(0.72, 0.45 * np.arange(1, 7), [0.6, 0.48, 0.36, 0.24, 0.12, 0.012])
B = PIModel(0.5, [0.2, 0.7], [0.3, -0.2], [0.1, 0.05])
LAG = LinearSystem([1.0, 50.0], [1.0, 100.0])  # biproper, minimum phase: invertible
U = 3.0 * np.sin(np.linspace(0, 4 * np.pi, 400)) + np.linspace(0, 1, 400)


def test_rshift_flattens_and_applies_in_order() -> None:
    c = A >> B >> A
    assert isinstance(c, Chain) and len(c.stages) == 3
    assert c.stages[0] is A and c.stages[1] is B and c.stages[2] is A
    assert np.array_equal(c(U), A(B(A(U))))
    nested = Chain.of(Chain.of(A, B), Chain.of(A))
    assert [s is t for s, t in zip(nested.stages, c.stages, strict=True)] == [True] * 3


def test_inverse_reverses_the_order() -> None:
    c = A >> B
    inv = c.inverse()
    assert len(inv.stages) == 2
    # first undo B, then A
    assert np.allclose(inv.stages[0].thresholds, B.inverse().thresholds)
    assert np.allclose(inv.stages[1].thresholds, A.inverse().thresholds)
    assert np.allclose(inv(c(U)), U, rtol=0, atol=1e-10)
    assert np.allclose(c(inv(U)), U, rtol=0, atol=1e-10)
    # the wrong order does not invert (the stages do not commute)
    wrong = Chain.of(A.inverse(), B.inverse())
    assert np.max(np.abs(c(wrong(U)) - U)) > 1e-3


def test_dynamic_chain_needs_dt_and_inverts() -> None:
    c = A >> LAG
    assert c.needs_dt and c.is_dynamic and not A.needs_dt
    with pytest.raises(ParameterError, match="needs the sample spacing dt"):
        c(U)
    y = c(U, dt=1e-3)
    assert np.allclose(c.inverse()(y, dt=1e-3), U, rtol=0, atol=1e-9)
    with pytest.raises(NotInvertibleError, match="strictly proper"):
        (A >> LinearSystem([1.0], [1.0, 1.0])).inverse()


def test_chunked_chain_equals_one_call() -> None:
    c = A >> LAG >> B
    one = c.simulate(U, dt=1e-3)
    a = c.simulate(U[:150], dt=1e-3)
    b = c.simulate(U[150:], state=a.state, dt=1e-3)
    assert np.array_equal(np.concatenate((a.y, b.y)), one.y)
    for s1, s2 in zip(b.state, one.state, strict=True):
        assert np.array_equal(s1, s2)
    assert len(c.default_state()) == 3


def test_serialisation_round_trip() -> None:
    c = A >> LAG >> B
    d = c.to_dict()
    assert d["type"] == "chain" and [s["type"] for s in d["stages"]] == ["pi", "lti", "pi"]
    c2 = model_from_dict(d)
    assert np.array_equal(c2(U, dt=1e-3), c(U, dt=1e-3))
    assert {"chain", "pi", "lti"} <= set(registered_types())


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: Chain(()), "a chain needs at least one stage"),
        (lambda: Chain((A, "x")), "chain stage 1 is str, not a Model"),
        (lambda: (A >> B).simulate(U, state=(A.default_state(),)),
         "chain state has 1 entries but the chain has 2 stages"),
        (lambda: Chain.from_dict({"type": "chain", "stages": []}), "chain.stages must be"),
        (lambda: model_from_dict({"type": "nope"}), "unknown model type 'nope'; known types"),
        (lambda: model_from_dict([1, 2]), "a model must be a JSON object, got list"),
    ],
)
def test_invalid_chains_name_the_rule(call, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        call()


def test_rshift_with_non_model_is_type_error() -> None:
    with pytest.raises(TypeError):
        A >> 3  # noqa: B018
