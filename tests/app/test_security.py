"""The server as an attacker and a crowd of students see it (issue 10), via TestClient.

Every test here failed on the code before issue 10: it names the numbered failure of the
issue it covers.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.settings import Settings
from core.pi import PIModel

PI = {"type": "pi", "p0": 1.0, "thresholds": [0.5], "weights": [1.0]}


def settings(tmp: Path, **kw: object) -> Settings:
    return Settings(viser_port=None, max_upload_bytes=6_000_000, **kw)


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    app = create_app(settings(tmp_path_factory.mktemp("state")))
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


@pytest.fixture
def code(client: TestClient) -> str:
    r = client.post("/api/sessions")
    assert r.status_code == 201
    return r.json()["code"]


def csv_text(n: int = 300, header: str = "t,u,y", run: str | None = None) -> str:
    t = np.arange(n) * 1e-3
    u = 3 * np.sin(2 * np.pi * 5 * t)
    y = PIModel.from_dict(PI)(u)
    rows = [f"{a:.6g},{b:.8g},{c:.8g}" for a, b, c in zip(t, u, y, strict=True)]
    if run is not None:
        rows = [f"{run},{r}" for r in rows]
    return f"{header}\n" + "\n".join(rows) + "\n"


def upload(client: TestClient, code: str, body: str | bytes, **params: str):
    return client.post(f"/api/sessions/{code}/recording", content=body,
                       headers={"Content-Type": "text/csv"}, params=params)


# ------------------------------------------------- 1. it reads its own files / 8. uploads
def test_a_body_naming_a_server_file_is_data(client: TestClient, code: str,
                                             tmp_path: Path) -> None:
    """Failure 1: a newline-free body was opened as a path (and its lines quoted back)."""
    secret = tmp_path / "numbers.csv"
    secret.write_text(csv_text(50))
    for body in (str(secret), str(tmp_path / "nope.csv"), "/etc/passwd"):
        for r in (client.post("/api/csv/preview", content=body,
                              headers={"Content-Type": "text/csv"}),
                  upload(client, code, body)):
            assert r.status_code == 422, r.text
            msg = r.json()["detail"]["message"]
            assert "no such file" not in msg and "root:" not in msg and "0.001" not in msg
    assert client.get(f"/api/sessions/{code}").json()["recording"] is None


def test_upload_accepts_utf16_like_the_cli(client: TestClient, code: str) -> None:
    """Failure 8: a UTF-16 CSV that ``hyst fit`` reads was refused by the upload."""
    r = upload(client, code, csv_text().encode("utf-16"))
    assert r.status_code == 201, r.text
    assert r.json()["samples"] == 300
    p = client.post("/api/csv/preview", content=csv_text().encode("utf-16"),
                    headers={"Content-Type": "text/csv"})
    assert p.status_code == 200 and p.json()["columns"] == ["t", "u", "y"]


def test_upload_reports_the_cleaning_notes(client: TestClient, code: str) -> None:
    """Failure 8: removed rows were not reported by the upload response."""
    lines = csv_text().splitlines()
    lines[10] = lines[10].rsplit(",", 1)[0] + ",nan"
    r = upload(client, code, "\n".join(lines) + "\n")
    assert r.status_code == 201
    notes = r.json()["notes"]
    assert any("removed 1 row" in n and "11" in n for n in notes), notes


def test_run_column_is_chosen_and_said(client: TestClient, code: str) -> None:
    """Failure 8: a file with a run column silently kept run 1 of 2."""
    a = csv_text(200, header="run,t,u,y", run="1")
    b = csv_text(200, header="run,t,u,y", run="2").split("\n", 1)[1]
    body = a + b
    r = upload(client, code, body)
    assert r.status_code == 201
    j = r.json()
    assert j["runs"] == ["1", "2"] and j["run"] == "1" and j["samples"] == 200
    assert any("holds 2 runs" in n and "run=" in n for n in j["notes"])
    r2 = upload(client, code, body, run="2")
    assert r2.status_code == 201 and r2.json()["run"] == "2"
    bad = upload(client, code, body, run="7")
    assert bad.status_code == 422 and "1, 2" in bad.json()["detail"]["message"]
