"""Shares of the session store per client and per session (issue 35 item 2)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from app.services.explore.config import Config
from app.services.session.sessions import SessionRegistry, StoreFullError
from app.services.storage.quotas import QuotaError, Quotas
from app.services.storage.store import SessionState, SessionStore
from core.recordings import Recording


def recording(n: int) -> Recording:
    t = np.arange(n) * 1e-3
    u = np.sin(2 * np.pi * 4 * t)
    return Recording(t, u, 0.5 * u, name="r")


def blob_size(rec: Recording) -> int:
    from app.services.storage.store import recording_to_blob

    return len(recording_to_blob(rec))


def test_one_client_cannot_take_more_than_its_share(tmp_path: Path) -> None:
    rec = recording(4000)
    each = blob_size(rec)
    store = SessionStore(tmp_path / "s.sqlite3", max_bytes=100 * each,
                         quotas=Quotas(client_bytes=int(3.5 * each)))
    for k in range(3):
        store.save(SessionState(code=f"a{k}", recording=rec, owner="10.0.0.1"))
    with pytest.raises(QuotaError, match="limit per computer") as err:
        store.save(SessionState(code="a3", recording=rec, owner="10.0.0.1"))
    assert err.value.limit == "client_bytes"
    assert not store.exists("a3")  # nothing stored, nothing of the client's evicted
    assert store.held("10.0.0.1")[0] == 3
    store.save(SessionState(code="b0", recording=rec, owner="10.0.0.2"))  # another client
    store.save(SessionState(code="t0", recording=rec, owner="10.0.0.1", teacher=True))
    # its own sessions unused for an hour make room, oldest first
    old = time.time() - 2 * store.protect_s
    store.save(SessionState(code="a0", recording=rec, owner="10.0.0.1", last_used=old - 5))
    store.save(SessionState(code="a1", recording=rec, owner="10.0.0.1", last_used=old))
    store.save(SessionState(code="a3", recording=rec, owner="10.0.0.1"))
    assert not store.exists("a0") and store.exists("a1") and store.exists("a3")


def test_one_session_and_session_count_shares(tmp_path: Path) -> None:
    rec = recording(4000)
    store = SessionStore(tmp_path / "s.sqlite3",
                         quotas=Quotas(session_bytes=blob_size(rec) // 2, client_sessions=3))
    with pytest.raises(QuotaError, match="limit per session") as err:
        store.save(SessionState(code="x", recording=rec, owner="10.0.0.1"))
    assert err.value.limit == "session_bytes"
    reg = SessionRegistry(store=store)
    for _ in range(3):
        reg.create(owner="10.0.0.1")
    with pytest.raises(QuotaError, match="opened 3 sessions") as err:
        reg.create(owner="10.0.0.1")
    assert err.value.limit == "client_sessions"
    reg.create(owner="10.0.0.2")
    reg.create(owner="10.0.0.1", teacher=True)  # a teacher is not counted


def test_the_heaviest_clients_oldest_idle_sessions_go_first(tmp_path: Path) -> None:
    small, big = recording(1000), recording(4000)
    store = SessionStore(tmp_path / "s.sqlite3", max_bytes=10**9)
    now = time.time()
    rows = [("light-old", "10.0.0.1", small, 99_000), ("heavy-new", "10.0.0.2", big, 7_300),
            ("heavy-old", "10.0.0.2", big, 8_000), ("heavy-recent", "10.0.0.2", big, 60),
            ("light-new", "10.0.0.1", small, 7_200)]
    for code, owner, rec, age in rows:
        store.save(SessionState(code=code, config=Config(), recording=rec, owner=owner,
                                last_used=now - age))
    size = {c: store.held(o)[1] for c, o, *_ in rows}
    assert size["heavy-old"] > size["light-old"]
    store.max_bytes = store.size() - 1  # one eviction is enough
    # plain LRU would have taken the light client's older session
    assert store.evict(now) == ["heavy-old"]
    store.max_bytes = 1
    assert store.evict(now) == ["heavy-new", "light-old", "light-new"]  # never the recent
    assert store.codes() == ["heavy-recent"] and store.full()


def test_a_teacher_always_opens_a_session_and_makes_room(tmp_path: Path) -> None:
    rec = recording(4000)
    each = blob_size(rec)
    store = SessionStore(tmp_path / "s.sqlite3", max_bytes=int(4.5 * each))
    reg = SessionRegistry(store=store)
    for owner, n in (("10.0.0.1", 3), ("10.0.0.2", 2)):
        for _ in range(n):
            reg.create(owner=owner).set_recording(rec)
            time.sleep(0.01)
    assert store.size() > store.max_bytes
    first = store.codes()[-1]  # the heaviest client's oldest session
    with pytest.raises(StoreFullError, match="ask the teacher to open a teacher session"):
        reg.create(owner="10.0.0.3")
    teacher = reg.create(owner="10.0.0.3", teacher=True)
    assert teacher.teacher and store.size() <= 0.9 * store.max_bytes
    assert not store.exists(first)
    assert store.held("10.0.0.2")[0] == 2  # the lighter client kept its sessions
    reg.create(owner="10.0.0.3")  # a student gets in again
