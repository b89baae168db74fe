"""Issue 18, item 3: one cost function over the model registry.

Every registered type prices its own run (:meth:`core.base.Model.cost`); the cost model
sums it over the model tree and refuses a request before any work: the bodies that ran for
minutes or took gigabytes are refused with a 422 without simulating anything. That the
priced work bounds the measured time is a benchmark (``benchmarks/bench_cost.py``), not a
timed test.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.explore import figures as F
from app.services.explore.cost import Limits, check_model
from app.services.session.actions import check_figure_names
from app.services.settings import Settings
from core.base import Model, registered_types
from core.exceptions import ParameterError
from core.lti import LinearSystem
from core.stages import (
    Advance,
    Asymmetry,
    AsymmetryInverse,
    CreepInverse,
    Drift,
)
from tests.core.model_zoo import DT, ZOO


def test_every_registered_type_prices_its_run() -> None:
    """Every type of the registry returns a finite, positive cost that grows with samples."""
    assert sorted(ZOO) == registered_types()
    for name, m in ZOO.items():
        small, big = m.cost(1_000, DT), m.cost(100_000, DT)
        for c in (small, big):
            assert math.isfinite(c.work) and c.work > 0, name
            assert math.isfinite(c.memory) and c.memory > 0, name
        assert big.work > small.work, name


def test_costs_are_not_linear_in_the_fields_where_the_work_is_not() -> None:
    """The overrides: asymmetry-inverse pays its bisection steps, a delay its buffer."""
    n = 10_000
    fwd, inv = Asymmetry(np.ones(50), 0.0, 1.0), AsymmetryInverse(np.ones(50), 0.0, 1.0)
    assert inv.cost(n, DT).work > 10 * fwd.cost(n, DT).work
    assert Advance(10.0).cost(n, 1e-4).memory > Advance(1e-3).cost(n, 1e-4).memory * 5
    lti = LinearSystem([1.0], np.poly(-np.arange(1, 11.0)))
    assert lti.cost(n, DT).work > n * lti.order**2


# ----------------------------------------------------------------------------- refusals
@pytest.mark.parametrize(
    ("model", "words"),
    [
        (Asymmetry(np.full(19_000, 1e-6), 0.0, 1.0), "'asymmetry'"),
        (AsymmetryInverse(np.full(19_000, 1e-6), 0.0, 1.0), "'asymmetry-inverse'"),
        (Drift(np.full(19_000, 1e-6), 1.0), "'drift'"),
        (CreepInverse(np.logspace(-3, 1, 9_000), np.full(9_000, 1e-5)), "creep-inverse"),
    ],
)
def test_check_model_refuses_by_the_priced_cost(model: Model, words: str) -> None:
    """The priced work alone refuses them (the creep-term and coarse work limits lifted)."""
    with pytest.raises(ParameterError) as e:
        check_model(model, 200_000, 5e-5, Limits(max_creep_terms=10**6, max_work=10**18))
    msg = str(e.value)
    assert words in msg and "units of work on 200,000 samples" in msg
    assert f"limit of {Limits.max_total_work:,.0f}" in msg


def test_memory_is_priced_too() -> None:
    """With the work limit lifted, the 2.9 GB eigenvalue problem is refused on memory."""
    lim = Limits(max_total_work=math.inf)
    with pytest.raises(ParameterError, match=r"MB of memory.*'asymmetry-inverse'.*19,000"):
        check_model(AsymmetryInverse(np.full(19_000, 1e-6), 0.0, 1.0), 1_000, 1e-3, lim)


def test_a_chain_costs_the_sum_of_its_stages() -> None:
    a, b = Drift(np.ones(3), 1.0), Asymmetry(np.ones(4), 0.0, 1.0)
    one = check_model(a, 1_000, 1e-3, Limits()).total_work
    two = check_model(b, 1_000, 1e-3, Limits()).total_work
    both = check_model(a >> b, 1_000, 1e-3, Limits()).total_work
    assert one + two < both <= one + two + 2_000


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    app = create_app(Settings(viser_port=None, max_upload_bytes=6_000_000))
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


def _body(stage: dict[str, Any], **kw: Any) -> dict[str, Any]:
    return {"model": stage, "signal": {"samples": 200_000, "duration": 10.0},
            "figures": ["time"], **kw}


@pytest.mark.parametrize(
    ("stage", "words"),
    [
        ({"type": "asymmetry", "coefficients": [1e-6] * 19_000, "center": 0.0, "scale": 1.0},
         "'asymmetry' stage (19,000 coefficients"),
        ({"type": "asymmetry-inverse", "coefficients": [1e-6] * 19_000, "center": 0.0,
          "scale": 1.0}, "'asymmetry-inverse' stage (19,000 coefficients"),
        ({"type": "drift", "coefficients": [1e-6] * 19_000, "span_s": 10.0},
         "'drift' stage (19,000 coefficients"),
        ({"type": "creep-inverse", "taus_s": list(np.logspace(-3, 1, 9_000)),
          "weights": [1e-5] * 9_000}, "creep-inverse has 9,000 terms"),
        ({"type": "advance", "delay_s": 2e5}, "advance's delay_s"),
    ],
)
def test_pathological_bodies_are_refused_before_any_work(
        client: TestClient, monkeypatch: pytest.MonkeyPatch, stage: dict[str, Any],
        words: str) -> None:
    """Each of these ran 13-120 s (up to 9.3 GB) on 200k samples; now a 422, and no model
    is simulated."""
    def never(*a: Any, **k: Any) -> Any:
        raise AssertionError("a model was simulated before its cost was checked")

    monkeypatch.setattr(Model, "simulate", never)
    r = client.post("/api/simulate", json=_body(stage))
    assert r.status_code == 422, r.text[:300]
    assert words in r.json()["detail"], r.json()["detail"]


def test_a_figure_asked_for_many_times_is_built_once(
        client: TestClient, monkeypatch: pytest.MonkeyPatch) -> None:
    """``["closed-loop"] * 10000`` built 10,000 figures (6 s); it now costs one."""
    calls: list[str] = []
    build = F.build

    def counting(name: str, res: Any) -> Any:
        calls.append(name)
        return build(name, res)

    monkeypatch.setattr(F, "build", counting)
    pi = {"type": "pi", "p0": 1.0, "thresholds": [0.5], "weights": [1.0]}
    r = client.post("/api/simulate", json={"model": pi, "figures": ["closed-loop"] * 10_000})
    assert r.status_code == 200, r.text[:300]
    assert list(r.json()["figures"]) == ["closed-loop"]
    assert calls == ["closed-loop"]


def test_figure_names_collapse_in_their_first_order() -> None:
    assert check_figure_names(["loop", "time", "loop", "time"]) == ["loop", "time"]
    with pytest.raises(ParameterError, match="unknown figure"):
        check_figure_names(["loop", "nope"] * 5_000)


def test_the_new_limits_are_published(client: TestClient) -> None:
    lim = client.get("/api/capabilities").json()["limits"]
    assert lim["max_total_work"] == Limits.max_total_work
    assert lim["max_memory_bytes"] == Limits.max_memory_bytes
