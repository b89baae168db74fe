"""Issue 18, item 3: one cost function over the model registry.

Every registered type prices its own run (:meth:`core.base.Model.cost`); the cost model
sums it over the model tree and refuses a request before any work. The priced work bounds
the measured time (a ratio, never an absolute timing), and the bodies that ran for minutes
or took gigabytes are refused with a 422 without simulating anything.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services import figures as F
from app.services.actions import check_figure_names
from app.services.cost import Limits, _children, check_model
from app.services.settings import Settings
from core.base import Model, RunCost, registered_types
from core.effects import (
    Advance,
    Asymmetry,
    AsymmetryInverse,
    Creep,
    CreepInverse,
    Delay,
    Drift,
    RateDependentPI,
)
from core.exceptions import ParameterError
from core.lti import LinearSystem
from core.pi import PIModel
from core.preisach import PreisachModel
from tests.core.model_zoo import DT, ZOO

#: Samples of the timed runs (small: the ratio, not the time, is checked).
N = 40_000
#: Generous upper bound of measured seconds per priced unit (about 1 ns is typical).
MAX_SECONDS_PER_UNIT = 40e-9


def _scaled() -> dict[str, Model]:
    """Zoo types scaled up in the sizes their cost depends on."""
    k = 60
    pre = PreisachModel(np.linspace(0.0, 2.0, 12), np.full((12, 3), 0.05), knots=[-1.0, 1.0])
    return {
        "pi x100": PIModel(1.0, np.linspace(0.05, 3.0, 100), np.full(100, 0.01)),
        "creep x40": Creep(np.logspace(-3, 1, 40), np.full(40, 0.01)),
        "creep-inverse x40": CreepInverse(np.logspace(-3, 1, 40), np.full(40, 0.01)),
        "drift x400": Drift(np.full(400, 1e-3), 2.0),
        "asymmetry x200": Asymmetry(np.full(200, 1e-4), 0.5, 4.0),
        "asymmetry-inverse x60": AsymmetryInverse(np.full(k, 1e-5), 0.5, 4.0),
        "delay long": Delay(N * DT), "advance long": Advance(N * DT),
        "rate-inverse x20": RateDependentPI(1.0, np.linspace(0.1, 2.0, 20),
                                            np.full(20, 0.02), 2e-5).inverse(),
        "lti order 8": LinearSystem([1.0], np.poly(-np.arange(1, 9) * 1e3)),
        "preisach-inverse x12": pre.inverse(),
    }


def _priced(m: Model, samples: int, dt: float) -> RunCost:
    total, todo = RunCost(0.0, 0.0), [m]
    while todo:
        x = todo.pop()
        total = total + x.cost(samples, dt)
        todo.extend(_children(x))
    return total


def _seconds(m: Model, u: np.ndarray) -> float:
    m.simulate(u[:64], dt=DT)  # compile the kernels first
    best = math.inf
    for _ in range(3):
        t = time.perf_counter()
        m.simulate(u, dt=DT)
        best = min(best, time.perf_counter() - t)
    return best


def test_every_registered_type_prices_its_run() -> None:
    """Every type of the registry returns a finite, positive cost that grows with samples."""
    assert sorted(ZOO) == registered_types()
    for name, m in ZOO.items():
        small, big = m.cost(1_000, DT), m.cost(100_000, DT)
        for c in (small, big):
            assert math.isfinite(c.work) and c.work > 0, name
            assert math.isfinite(c.memory) and c.memory > 0, name
        assert big.work > small.work, name


def test_priced_work_bounds_the_measured_time() -> None:
    """Seconds per priced unit stay under one generous constant for every type, scaled up."""
    u = 3.0 * np.sin(np.linspace(0.0, 40.0 * np.pi, N))
    ratios: dict[str, float] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, m in {**ZOO, **_scaled()}.items():
            ratios[name] = _seconds(m, u) / _priced(m, N, DT).work
    worst = max(ratios, key=ratios.__getitem__)
    assert ratios[worst] < MAX_SECONDS_PER_UNIT, (worst, ratios[worst], ratios)


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
    t = time.perf_counter()
    r = client.post("/api/simulate", json=_body(stage))
    assert r.status_code == 422, r.text[:300]
    assert words in r.json()["detail"], r.json()["detail"]
    assert time.perf_counter() - t < 10.0  # generous: it ran for 13 s to minutes


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
