"""A bounded hypothesis fuzz of the REST API: no body, model or CSV yields a 500 (issue 10)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.server import create_app
from app.services.settings import Settings

TYPES = ["pi", "chain", "rate", "creep", "lag", "resonance", "delay", "lti", "deadzone",
         "initial-memory", "offset", "drift", "asymmetry", "digitized", "mpi", "gpi-tanh"]
FIELDS = ["p0", "thresholds", "weights", "beta_s", "taus_s", "tau_s", "freq_hz", "damping",
          "delay_s", "num", "den", "stages", "model", "history", "offset", "state0"]
numbers = st.one_of(st.floats(allow_nan=False, allow_infinity=False), st.integers(-10, 10**9),
                    st.sampled_from([0.0, 1e-300, 5e-324, 1e300, -1.0, 0.5]))
scalars = st.one_of(numbers, st.text(max_size=5), st.booleans(), st.none())
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=6),
        st.dictionaries(st.sampled_from(FIELDS + ["type"]), inner, max_size=4),
        st.fixed_dictionaries({"type": st.sampled_from(TYPES)},
                              optional={f: inner for f in FIELDS}),
    ),
    max_leaves=20,
)
models = st.fixed_dictionaries({"type": st.sampled_from(TYPES)},
                               optional={f: values for f in FIELDS})
FUZZ = settings(max_examples=60, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    app = create_app(Settings(viser_port=None, max_samples=5000, max_operators=40))
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


@FUZZ
@given(model=models, samples=st.integers(-5, 6000), figure=st.sampled_from(
    ["loop", "time", "inverse", "operators", "loading", "digitized", "nope"]))
def test_simulate_never_500(client: TestClient, model: dict, samples: int,
                            figure: str) -> None:
    body = {"model": model, "signal": {"samples": samples}, "figures": [figure]}
    r = client.post("/api/simulate", json=body)
    assert r.status_code < 500, (body, r.text[:300])


@FUZZ
@given(model=models)
def test_session_config_and_parameter_set_never_500(client: TestClient, model: dict) -> None:
    code = client.app.state.registry.create().code  # (POST /api/sessions is rate-limited)
    r = client.patch(f"/api/sessions/{code}/config", json={"model": model})
    assert r.status_code < 500, (model, r.text[:300])
    r = client.put(f"/api/sessions/{code}/parameter-set", json=model)
    assert r.status_code < 500, (model, r.text[:300])
    for url in (f"/api/sessions/{code}/figures", f"/api/sessions/{code}/export/json"):
        assert client.get(url).status_code < 500, (model, url)


@FUZZ
@given(body=st.one_of(st.binary(max_size=400), st.text(alphabet=",;\t\n\"#0123456789.e-naAt ",
                                                       max_size=400)))
def test_csv_never_500(client: TestClient, body: bytes | str) -> None:
    code = client.app.state.registry.create().code  # (POST /api/sessions is rate-limited)
    for url in ("/api/csv/preview", f"/api/sessions/{code}/recording"):
        r = client.post(url, content=body, headers={"Content-Type": "text/csv"})
        assert r.status_code < 500, (body, r.text[:300])
