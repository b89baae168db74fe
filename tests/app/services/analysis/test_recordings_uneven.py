"""Uploads with uneven time stamps: the choice (resample with the step shown, or keep) in
the service, the REST API and the command line; no reader option names in the messages."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.analysis.recordings import (
    UnevenUpload,
    read_recordings,
    read_upload,
    seconds_text,
)
from app.services.runs.inputs import CommandError
from app.services.settings import Settings

INTERNAL = ("resample=", "uneven=", "'keep'", ".resampled()")


def _jittered(n: int = 200) -> tuple[str, np.ndarray, np.ndarray]:
    """Semicolon CSV with decimal commas, a unit row, one NaN row and jittered time;
    returns the text and the (t, u) of its numeric rows as printed."""
    rng = np.random.default_rng(7)
    t = np.arange(n) * 2e-3 + rng.uniform(-4e-4, 4e-4, n)
    t[0] = 0.0
    u = 3 * np.sin(2 * np.pi * 4 * t)
    rows = []
    for k in range(n):
        cells = [f"{t[k]:.6f}", "NaN" if k == 40 else f"{u[k]:.5f}", f"{0.5 * u[k]:.5f}"]
        rows.append(";".join(c.replace(".", ",") for c in cells))
    text = "t;u;y\ns;V;um\n" + "\n".join(rows) + "\n"
    keep = [k for k in range(n) if k != 40]
    tp = np.array([float(f"{x:.6f}") for x in t])
    up = np.array([float(f"{x:.5f}") for x in u])
    return text, tp[keep], up[keep]


def test_upload_asks_then_resamples_onto_the_step_offered_or_keeps() -> None:
    text, t, u = _jittered()
    with pytest.raises(UnevenUpload) as ei:
        read_upload(text)
    msg = str(ei.value)
    assert not any(x in msg for x in INTERNAL), msg
    timing = ei.value.timing
    # the reader checks every printed time stamp (the NaN row still has one)
    t_all = np.sort(np.concatenate([t, [float(text.splitlines()[42].split(";")[0]
                                                 .replace(",", "."))]]))
    assert timing.step == pytest.approx(np.median(np.diff(t_all)), rel=1e-12)
    assert seconds_text(timing.step) in msg and "keep" in msg
    rec = read_upload(text, timing="resample", step=timing.step).recording
    assert rec.is_uniform and rec.dt == pytest.approx(timing.step, rel=1e-12)
    np.testing.assert_allclose(rec.u, np.interp(rec.t, t, u), atol=1e-12)
    up = read_upload(text, timing="keep")
    np.testing.assert_allclose(up.recording.t, t, atol=1e-12)
    assert up.time_steps == "the uneven time stamps were kept as measured"
    assert not any(x in c for c in up.recording.cleaning for x in INTERNAL)


def test_seconds_text_rounds_before_choosing_the_unit() -> None:
    assert [seconds_text(x) for x in (0.0009997, 6.07e-4, 2.5, 4e-5)] == [
        "1 ms", "607 µs", "2.5 s", "40 µs"]


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(viser_port=None))) as c:
        yield c


def test_rest_preview_offers_the_choice_and_upload_takes_it(client: TestClient) -> None:
    text, t, u = _jittered()
    h = {"Content-Type": "text/csv"}
    p = client.post("/api/csv/preview", content=text, headers=h).json()
    assert p["uneven"]["choices"] == ["resample", "keep"]
    step = p["uneven"]["step_s"]
    code = client.post("/api/sessions").json()["code"]
    url = f"/api/sessions/{code}/recording"
    r = client.post(url, content=text, headers=h)
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail["uneven"]["step_s"] == step and detail["line"] > 2 and detail["column"] == 0
    assert not any(x in detail["message"] for x in INTERNAL)
    r = client.post(url, content=text, headers=h, params={"timing": "resample", "step": step})
    assert r.status_code == 201, r.text
    assert "resampled onto an even grid of" in r.json()["time_steps"]
    assert r.json()["t_range"][1] == pytest.approx(step * np.floor(t[-1] / step), rel=1e-9)
    for bad in ({"timing": "both"}, {"step": "0.001"}, {"timing": "keep", "step": "0.001"}):
        r = client.post(url, content=text, headers=h, params=bad)
        assert r.status_code == 422, bad
    # an even file needs no choice and says nothing about it
    even = "t,u,y\n" + "\n".join(f"{k / 1000},{k % 7},{k % 5}" for k in range(50))
    assert "uneven" not in client.post("/api/csv/preview", content=even, headers=h).json()
    r = client.post(url, content=even, headers=h)
    assert r.status_code == 201 and r.json().get("time_steps") is None


def test_command_line_offers_its_option(tmp_path: Path) -> None:
    text, _, _ = _jittered()
    f = tmp_path / "j.csv"
    f.write_text(text)
    with pytest.raises(CommandError, match=r"pass --resample to interpolate onto an even grid "
                                           r"of \S+ ms steps") as ei:
        read_recordings([f])
    assert not any(x in str(ei.value) for x in INTERNAL)
