"""A bounded hypothesis fuzz of the REST API: no body, model or CSV yields a 500 (issues 10, 18).

The corpus holds the classes of issue 18: ``NaN``/``Infinity`` literals, lone surrogates
in keys and strings (also in a UTF-16 CSV) and absurd values (``delay_s = 1e300`` of a
delay or an advance). :func:`test_every_route_never_500` takes its routes from the app's
OpenAPI document, so a new route is fuzzed without changing this file.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.server import create_app
from app.services.settings import Settings

TYPES = ["pi", "advance", "chain", "rate", "creep", "lag", "resonance", "delay", "lti", "deadzone",
         "initial-memory", "offset", "drift", "asymmetry", "digitized", "mpi", "gpi-tanh"]
FIELDS = ["p0", "thresholds", "weights", "beta_s", "taus_s", "tau_s", "freq_hz", "damping",
          "delay_s", "num", "den", "stages", "model", "history", "offset", "state0"]
numbers = st.one_of(st.floats(), st.integers(-10, 10**9),  # NaN and +-inf included
                    st.sampled_from([0.0, 1e-300, 5e-324, 1e300, -1.0, 0.5]))
#: text with lone surrogates (hypothesis leaves them out unless asked)
texts = st.text(st.characters(min_codepoint=0xD7F0, max_codepoint=0xE010,
                              blacklist_categories=()) | st.characters(), max_size=5)
scalars = st.one_of(numbers, texts, st.booleans(), st.none())
values = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=6),
        st.dictionaries(st.sampled_from(FIELDS + ["type"]) | texts, inner, max_size=4),
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


def send_json(client: TestClient, method: str, url: str, doc: object):
    """``doc`` as Python's json writes it: NaN/Infinity literals, surrogates as escapes
    (a client's own encoder would refuse both before sending)."""
    return client.request(method, url, content=json.dumps(doc).encode(),
                          headers={"Content-Type": "application/json"})


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
    r = send_json(client, "POST", "/api/simulate", body)
    assert r.status_code < 500, (body, r.text[:300])


@FUZZ
@given(model=models)
def test_session_config_and_parameter_set_never_500(client: TestClient, model: dict) -> None:
    code = client.app.state.registry.create().code  # (POST /api/sessions is rate-limited)
    r = send_json(client, "PATCH", f"/api/sessions/{code}/config", {"model": model})
    assert r.status_code < 500, (model, r.text[:300])
    r = send_json(client, "PUT", f"/api/sessions/{code}/parameter-set", model)
    assert r.status_code < 500, (model, r.text[:300])
    for url in (f"/api/sessions/{code}/figures", f"/api/sessions/{code}/export/json"):
        assert client.get(url).status_code < 500, (model, url)


@FUZZ
@given(body=st.one_of(st.binary(max_size=400), st.text(alphabet=",;\t\n\"#0123456789.e-naAt ",
                                                       max_size=400),
                     st.lists(texts, max_size=8).map(  # UTF-16 with BOM, lone surrogates
                         lambda t: "t,u,y\n0,1,2\n".join(t).encode("utf-16", "surrogatepass"))))
def test_csv_never_500(client: TestClient, body: bytes | str) -> None:
    code = client.app.state.registry.create().code  # (POST /api/sessions is rate-limited)
    for url in ("/api/csv/preview", f"/api/sessions/{code}/recording"):
        r = client.post(url, content=body, headers={"Content-Type": "text/csv"})
        assert r.status_code < 500, (body, r.text[:300])


# ----------------------------------------------------------------------- every route
#: hostile bodies of issue 18, sent raw (the JSON encoder of a client would refuse some)
HOSTILE = [b'{"mismatch": NaN}', b'{"signal": {"amplitude": Infinity}}', b'[-Infinity]',
           b'{"\\ud800": 1}', b'{"kind": "fit\\udc00"}', b'{"type": "advance", "delay_s": 1e300}',
           b'{"model": {"type": "advance", "delay_s": 1e300}}', b'{"n": 1e400}',
           b'{"model": {"type": "delay", "delay_s": 1e300}, "signal": {"samples": 100}}',
           b'\xed\xa0\x80', "t,u,y\n1,\ud800,2\n".encode("utf-16", "surrogatepass")]
bodies = st.one_of(
    st.sampled_from(HOSTILE),
    values.map(lambda v: json.dumps(v).encode()),  # allow_nan: NaN/Infinity literals
    models.map(lambda m: json.dumps({"model": m, "signal": {"samples": 100}}).encode()),
    st.binary(max_size=100),
)
PARAMS = {"name": st.sampled_from(["paper001-example1", "nope", "..", "x" * 300]),
          "job_id": st.sampled_from(["0", "nope", "-1"]),
          "fmt": st.sampled_from(["json", "mat", "c", "nope"])}


def _routes() -> list[tuple[str, str]]:
    """Every (method, path) of the OpenAPI document, but the endless event stream."""
    spec = create_app(Settings(viser_port=None)).openapi()
    out = []
    for path, ops in spec["paths"].items():
        for method, op in ops.items():
            kinds = {k for r in op["responses"].values() for k in r.get("content", {})}
            if "text/event-stream" not in kinds:  # never ends; test_events*
                out.append((method.upper(), path))
    return out


ROUTES = _routes()


def test_the_fuzz_covers_the_routes() -> None:
    assert len(ROUTES) >= 20 and ("POST", "/api/simulate") in ROUTES


@pytest.mark.parametrize(("method", "path"), ROUTES, ids=[f"{m} {p}" for m, p in ROUTES])
@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(body=bodies, ctype=st.sampled_from(["application/json", "text/csv", None]),
       data=st.data())
def test_every_route_never_500(client: TestClient, method: str, path: str, body: bytes,
                               ctype: str | None, data: st.DataObject) -> None:
    code = client.app.state.registry.create().code
    url = re.sub(r"\{(\w+)\}", lambda m: code if m[1] == "code"
                 else data.draw(PARAMS.get(m[1], st.just("x")), label=m[1]), path)
    headers = {} if ctype is None else {"Content-Type": ctype}
    r = client.request(method, url, content=body if method != "GET" else None,
                       headers=headers)
    assert r.status_code < 500, (method, url, body[:200], r.text[:300])
