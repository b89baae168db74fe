"""Issue 35 item 5: one strict reader for every body, whatever its content type.

On 9b4b66d 14 of 12,000 fuzzed requests answered 500, from four causes: a model ``type``
that is a list; a number of 4,400 digits in a parameter set or lesson sent as text/plain,
TOML or multipart (the same body as JSON got 422); a TOML datetime in a lesson; a lone
surrogate in a text/plain lesson. Each answers 422 naming where the problem is.
"""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.guard.jsonbody import DocumentError, read_document
from app.services.settings import Settings

BIG = "1" + "0" * 4400
PI = {"type": "pi", "p0": 1.0, "thresholds": [0.5], "weights": [1.0]}
STEP = '{"title": "a", "prompt": "p", "preset": "paper001-example1"%s}'
TYPES = ("text/plain", "application/toml", "multipart/form-data; boundary=x",
         "application/json", "")


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(viser_port=None)),
                    raise_server_exceptions=False) as c:
        yield c


@pytest.fixture(scope="module")
def code(client: TestClient) -> str:
    return client.post("/api/sessions").json()["code"]


def _send(client: TestClient, method: str, path: str, body: str, ctype: str):  # noqa: ANN202
    headers = {"Content-Type": ctype} if ctype else {}
    return client.request(method, path, content=body.encode("utf-8", "surrogatepass"),
                          headers=headers)


def test_a_model_type_that_is_a_list(client: TestClient, code: str) -> None:
    listed = {"type": ["pi"]}
    for method, path, body, where in (
            ("PATCH", f"/api/sessions/{code}/config", {"model": listed}, "model.type"),
            ("POST", "/api/simulate", {"model": listed}, "model.type"),
            ("PUT", f"/api/sessions/{code}/parameter-set", listed, "body.type"),
            ("POST", "/api/lessons/check",
             {"title": "x", "steps": [{"title": "a", "prompt": "p", "model": listed}]},
             "step 1 (a): model.type"),
            ("POST", "/api/simulate", {"model": {"type": "chain", "stages": [
                PI, {"type": {"a": 1}}]}}, "model.stages[1].type")):
        r = _send(client, method, path, json.dumps(body), "application/json")
        assert r.status_code == 422, (path, r.text)
        detail = r.json()["detail"]
        assert where in detail and ("not a list" in detail or "not an object" in detail)


@pytest.mark.parametrize("ctype", TYPES)
def test_a_number_of_4400_digits_in_any_content_type(client: TestClient, code: str,
                                                     ctype: str) -> None:
    pset = json.dumps(PI).replace("1.0", BIG, 1)
    r = _send(client, "PUT", f"/api/sessions/{code}/parameter-set", pset, ctype)
    assert r.status_code == 422 and "body.p0 is a number of 4,401 digits" in r.text
    lesson = '{"title": "x", "steps": [%s]}' % (STEP % f', "mismatch": {BIG}')
    r = _send(client, "POST", "/api/lessons/check", lesson, ctype)
    assert r.status_code == 422 and "steps[0].mismatch is a number of 4,401" in r.text
    toml = f'title = "x"\n[[steps]]\ntitle = "a"\nprompt = "p"\nmismatch = {BIG}\n'
    r = _send(client, "POST", "/api/lessons/check", toml, ctype)
    assert r.status_code == 422 and "line 5 holds an integer of more than" in r.text


def test_a_toml_date_and_a_lone_surrogate_in_a_lesson(client: TestClient) -> None:
    r = _send(client, "POST", "/api/lessons/check",
              'title = 1979-05-27\n[[steps]]\ntitle = "a"\nprompt = "p"\n'
              'preset = "paper001-example1"\n', "application/toml")
    assert r.status_code == 422 and "lesson.title is a date or time (1979-05-27)" in r.text
    r = _send(client, "POST", "/api/lessons/check",
              '{"title": "x\\ud800", "steps": [%s]}' % (STEP % ""), "text/plain")
    assert r.status_code == 422 and "body.title holds the unpaired surrogate" in r.text
    r = _send(client, "POST", "/api/lessons/check",
              'title = "x"\n[[steps]]\ntitle = "a"\nprompt = "p"\npreset = '
              '"paper001-example1"\n[steps.input]\nperiods = 1979-05-27T07:32:00Z\n', "")
    assert r.status_code == 422 and "lesson.steps[0].input.periods is a date" in r.text


def test_the_reader_refuses_what_python_parsers_let_through() -> None:
    assert read_document('{"a": [1, 2.5, "x"]}') == {"a": [1, 2.5, "x"]}
    assert read_document('a = 1\nb = "x"', toml=True) == {"a": 1, "b": "x"}
    for text, where in (('{"a": NaN}', "body.a"), ('{"a": [1e400]}', "body.a[0]"),
                        (f'{{"a": {{"b c": -{BIG[:400]}}}}}', 'body.a["b c"]'),
                        ("a = nan", "body.a"), (f"a = [{BIG[:400]}]", "body.a[0]"),
                        ("a = 07:32:00", "body.a")):
        with pytest.raises(DocumentError) as err:
            read_document(text, toml=True)
        assert err.value.path == where and str(err.value).startswith(where)
