"""A damaged store file is moved aside at start-up and a fresh store is started."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.server import create_app
from app.services.explore.config import Config
from app.services.settings import Settings
from app.services.storage.store import SessionState, SessionStore
from core.pi import PIModel


def _filled(db: Path, n: int = 300) -> None:
    store = SessionStore(db)
    pi = PIModel(0.5, list(np.linspace(0.05, 1.6, 24)), [0.1] * 24)
    config = Config().with_model(pi.to_dict())  # about 700 bytes a row
    for i in range(n):  # enough rows for many pages
        store.save(SessionState(code=f"code-{i:04d}", config=config))
    store.close()


def _truncate(db: Path) -> None:
    with open(db, "r+b") as f:
        f.truncate(os.path.getsize(db) // 2)


def _garbage_in_the_middle(db: Path) -> None:
    size = os.path.getsize(db)
    with open(db, "r+b") as f:
        f.seek(size // 2)
        f.write(b"\xde\xad\xbe\xef" * 2048)


@pytest.mark.parametrize("damage", [_truncate, _garbage_in_the_middle])
def test_a_damaged_file_is_moved_aside_and_the_server_starts(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], damage) -> None:
    db = tmp_path / "sessions.sqlite3"
    _filled(db)
    assert not (tmp_path / "sessions.sqlite3-wal").exists()  # checkpointed on close
    damage(db)
    with TestClient(create_app(Settings(viser_port=None, state_dir=str(tmp_path)))) as c:
        err = capsys.readouterr().err
        moved = [p for p in tmp_path.iterdir() if ".damaged-" in p.name]
        assert len(moved) == 1 and moved[0].parent == tmp_path
        assert f"the session store {db} is damaged" in err and str(moved[0]) in err
        assert "a fresh store was started" in err and "session(s)" in err
        assert stat.S_IMODE(moved[0].stat().st_mode) == 0o600
        code = c.post("/api/sessions").json()["code"]  # the fresh store works
        assert c.get(f"/api/sessions/{code}").status_code == 200
        assert c.patch(f"/api/sessions/{code}/config", json={"mismatch": 0.1}).status_code \
            == 200
        assert c.get("/api/sessions/code-0001").status_code == 404
    again = SessionStore(db)  # the fresh store keeps what was saved after the move
    restored = int(err.split(" session(s)")[0].rsplit(" ", 1)[1])  # and the readable ones
    assert code in again.codes() and len(again) == restored + 1 and restored > 0
    again.close()


def test_a_sound_file_is_left_alone(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "sessions.sqlite3"
    _filled(db, 5)
    store = SessionStore(db)
    assert len(store) == 5 and capsys.readouterr().err == ""
    assert not [p for p in tmp_path.iterdir() if ".damaged-" in p.name]
    store.close()


def test_a_file_that_is_no_database_is_moved_aside(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "sessions.sqlite3"
    db.write_bytes(b"this is not a database" * 100)
    store = SessionStore(db)
    assert len(store) == 0 and "file is not a database" in capsys.readouterr().err
    moved = [p for p in tmp_path.iterdir() if ".damaged-" in p.name]
    assert len(moved) == 1 and moved[0].read_bytes().startswith(b"this is not")
    store.close()
