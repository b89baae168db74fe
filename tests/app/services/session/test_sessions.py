"""Live sessions and their registry (``app.services.session.sessions``):
codes, LRU, listeners, versions."""

from __future__ import annotations

import threading

import pytest

from app.services.explore import config as S
from app.services.session import sessions as SS


def test_registry_codes_lru_and_broadcast() -> None:
    reg = SS.SessionRegistry(max_sessions=3)
    a = reg.create()
    assert len(a.code.replace("-", "")) == 16 and reg.get(a.code.upper()) is a
    b = reg.create()
    with pytest.raises(KeyError):  # codes are made by the server only (issue 10)
        reg.get_or_create("Class-1")
    reg.get(a.code)  # a is now the most recent
    reg.create()
    reg.create()  # b leaves memory, not the store
    assert b.code not in [s.code for s in reg.all()]
    assert reg.get(b.code).code == b.code and len(reg) == 4
    with pytest.raises(KeyError):
        reg.get("x")
    model = {**S.EXAMPLE1, "p0": 1.0}
    assert reg.push_model(model) == 4
    assert all(s.config.model["p0"] == 1.0 for s in reg.all())


def test_session_listeners_and_versions() -> None:
    s = SS.Session(code="abc")
    seen: list[int] = []
    cb = lambda sess, cfg, v: seen.append(v)  # noqa: E731
    s.add_listener(cb)
    s.set_config(S.Config(mismatch=0.1))
    s.update(lambda c: S.Config(mismatch=0.2))
    s.touch()
    s.remove_listener(cb)
    s.set_config(S.Config())
    assert seen == [1, 2, 3] and s.version == 4


def test_concurrent_updates_are_not_lost() -> None:
    s = SS.Session(code="abc")

    def bump() -> None:
        for _ in range(200):
            s.update(lambda c: S.Config(mismatch=c.mismatch + 0.001))

    threads = [threading.Thread(target=bump) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert s.version == 800 and s.config.mismatch == pytest.approx(0.8)
