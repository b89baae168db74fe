"""``POST /api/controls``: the sliders of any model document, as both interfaces draw them;
the session's config refuses a broken rule in the slider labels and never stays blocked."""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.explore.simulation import preset_doc
from app.services.settings import Settings
from tests.app.services.explore.test_controls import toy  # noqa: F401 - the fixture

SETTINGS = Settings(viser_port=None, max_upload_bytes=200_000, max_operators=40)


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(SETTINGS)) as c:
        yield c


def test_dead_zone_gpi_gets_sliders_for_every_part(client: TestClient) -> None:
    r = client.post("/api/controls", json={"model": preset_doc("paper001-example4")["model"]})
    assert r.status_code == 200
    body = r.json()
    groups = {g["key"]: g for g in body["groups"]}
    assert list(groups) == ["pi.p0", "pi.thresholds", "pi.weights", "deadzone.thresholds",
                            "deadzone.weights"]
    rho = groups["deadzone.thresholds"]["sliders"]
    assert len(rho) == 23 and rho[0]["label"] == "ρ-11" and rho[11]["fixed"] is True
    r3 = groups["pi.thresholds"]["sliders"][2]
    assert (r3["label"], r3["below"], r3["above"]) == ("r3", "pi.thresholds[1]",
                                                       "pi.thresholds[3]")
    tanh = client.post("/api/controls", json={"model": preset_doc("paper001-example6")["model"]})
    labels = [s["label"] for g in tanh.json()["groups"] for s in g["sliders"]]
    assert labels[-8:] == ["a0", "a1", "a2", "a3", "b0", "b1", "b2", "b3"]
    rising = next(g for g in tanh.json()["groups"] if g["key"] == "envelope.a")
    assert rising["unit"] == "a0, a3: output units; a1: per input unit"  # a2: a pure number


def test_a_new_type_gets_sliders_through_the_route(client: TestClient, toy: type) -> None:  # noqa: F811
    r = client.post("/api/controls",
                    json={"model": {"type": "toy-springs", "stiffness": 2.0, "gaps": [1, 3]}})
    assert r.status_code == 200
    assert [s["label"] for g in r.json()["groups"] for s in g["sliders"]] == ["k", "g1", "g2"]


@pytest.mark.parametrize("model, words", [
    ({"type": "pi", "p0": 1, "thresholds": [0.5, 2, 1], "weights": [1, 1, 1]},
     "r2 = 2 must stay below r3 = 1"),
    ({"type": "pi", "p0": 1, "thresholds": [-1, 2], "weights": [1, 1]},
     "r1 = -1 must be > 0 (thresholds r_i)"),
    ({"type": "nope"}, "unknown model type"),
    ({"p0": 1}, "a JSON object with a \"type\""),
    ({"type": "pi", "p0": 1, "thresholds": list(range(1, 60)), "weights": [1] * 59},
     "at most 40"),
    ({"type": "chain", "stages": [{"type": "chain", "stages": [{}]}] * 2}, ""),
])
def test_bad_models_are_refused_with_a_message(client: TestClient, model: dict,
                                               words: str) -> None:
    r = client.post("/api/controls", json={"model": model})
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert words in (detail if isinstance(detail, str) else json.dumps(detail))


def test_hostile_bodies_never_give_a_500(client: TestClient) -> None:
    deep = '{"model": ' + '{"type": "chain", "stages": [' * 200 + "{}" + "]}" * 200 + "}"
    for body in (deep, "[]", '{"model": 1}', '{"model": {"type": "pi"}, "x": 1}', "{"):
        r = client.post("/api/controls", content=body,
                        headers={"Content-Type": "application/json"})
        assert r.status_code in (400, 413, 422), (body[:40], r.status_code)


def test_a_refused_config_names_the_slider_and_the_next_change_applies(
        client: TestClient) -> None:
    code = client.post("/api/sessions").json()["code"]
    m = preset_doc("paper001-example1")["model"]
    bad = dict(m, thresholds=[0.45, 0.9, 3.345, 1.8, 2.25, 2.7])
    r = client.patch(f"/api/sessions/{code}/config", json={"model": bad})
    assert r.status_code == 422
    assert r.json()["detail"] == ("r3 = 3.345 must stay below r4 = 1.8: the thresholds r_i "
                                  "must be increasing")
    ok = dict(m, weights=[0.5, 0.48, 0.36, 0.24, 0.12, 0.012])
    r = client.patch(f"/api/sessions/{code}/config", json={"model": ok})
    assert r.status_code == 200 and r.json()["config"]["model"]["weights"][0] == 0.5


def test_a_slider_move_is_clamped_by_the_one_implementation_of_the_rules(
        client: TestClient) -> None:
    """``POST /api/controls/clamp``: the web page asks the server for every move, so the
    rules (limits, increasing neighbours, whole numbers) live once, in
    ``app/services/explore/controls.py``, which the viser GUI calls too; the page's
    ``static/controls.js`` holds no copy of them."""
    from pathlib import Path

    from app.services.explore import controls as C

    doc = preset_doc("paper001-example1")["model"]
    r = client.post("/api/controls/clamp", json={"model": doc, "path": "thresholds[2]",
                                                 "value": 3.345})
    assert r.status_code == 200, r.text
    assert r.json() == {"value": pytest.approx(1.799), "note": "r3 stops at 1.799, just "
                        "below r4 = 1.8: the thresholds r_i must increase"}
    for path, value in [("thresholds[0]", -1.0), ("weights[1]", -0.3), ("p0", 0.9)]:
        done = C.clamp(doc, path, value)  # what the viser GUI applies
        got = client.post("/api/controls/clamp",
                          json={"model": doc, "path": path, "value": value}).json()
        assert got == {"value": pytest.approx(done.value), "note": done.note}
    gpi = preset_doc("paper001-example4")["model"]
    got = client.post("/api/controls/clamp", json={"model": gpi, "value": 0.0,
                                                   "path": "deadzone.thresholds[12]"}).json()
    assert got["value"] == pytest.approx(0.001) and "ρ1 stops at 0.001, just above ρ0" in \
        got["note"]
    # refused in words: no such slider, not a model, not a number
    bad = client.post("/api/controls/clamp", json={"model": doc, "path": "thresholds[9]",
                                                   "value": 1.0})
    assert bad.status_code == 422 and "no slider at 'thresholds[9]'" in bad.text
    assert client.post("/api/controls/clamp", json={"model": {"p0": 1}, "path": "p0",
                                                    "value": 1.0}).status_code == 422
    assert client.post("/api/controls/clamp", json={"model": doc, "path": "p0",
                                                    "value": "x"}).status_code == 422
    js = (Path(__file__).resolve().parents[3] / "static" / "controls.js").read_text()
    assert "/api/controls/clamp" in js
    assert not any(rule in js for rule in ("s.lower", "s.upper", "s.strict", "s.below",
                                           "s.above", "Math.round"))
