"""One figure per lesson step for the class (issue 33): the sessions on the class's step share
the step's figures, computed once; a student who moved gets their own."""

from __future__ import annotations

import threading
from dataclasses import replace
from typing import Any

import pytest

from app.services.explore import shared, simulation
from app.services.explore.config import Config
from app.services.explore.payload import result_payload
from app.services.explore.shared import STEP_RESULTS, SharedResults
from app.services.session import actions
from app.services.session.sessions import Session, SessionRegistry
from app.services.settings import Settings
from app.services.teaching import lessons

N_STUDENTS = 12
VIEWS = ["loop", "time"]
#: The computation itself, for the references (not counted).
REAL_COMPUTE = simulation.compute


@pytest.fixture
def computations(monkeypatch: pytest.MonkeyPatch) -> list[Config]:
    """The configs :func:`simulation.compute` ran on (every figure computation passes
    there), the shared outcomes forgotten first."""
    seen: list[Config] = []
    real = simulation.compute

    def counting(config: Config, **kw: Any) -> simulation.Result:
        seen.append(config)
        return real(config, **kw)

    monkeypatch.setattr(simulation, "compute", counting)
    STEP_RESULTS.clear()
    yield seen
    STEP_RESULTS.clear()


def _class_on_step(step: int) -> tuple[SessionRegistry, list[Session]]:
    reg = SessionRegistry()
    students = [reg.create() for _ in range(N_STUDENTS)]
    lessons.start(reg, lessons.builtin_lesson("pi-basics"), step=step)
    return reg, students


def _alone(session: Session, names: list[str]) -> dict[str, Any]:
    """The figures body of ``session``'s config computed on its own (no sharing), but for
    how long it took."""
    cfg, v = session.snapshot()
    return _timeless(result_payload(REAL_COMPUTE(cfg, views=names, version=v), names))


def _timeless(body: dict[str, Any]) -> dict[str, Any]:
    return {k: x for k, x in body.items() if k != "elapsed_ms"}


def test_the_class_on_a_step_computes_its_figures_once(computations: list[Config]) -> None:
    _, students = _class_on_step(2)
    settings = Settings()
    bodies = [actions.session_figures(s, VIEWS, settings) for s in students]
    assert len(computations) == 1  # without the shared outcome: one per student
    step_cfg = students[0].snapshot()[0]
    assert computations[0].to_dict() == step_cfg.to_dict()
    for s, body in zip(students, bodies, strict=True):
        assert body["version"] == s.snapshot()[1]  # each session's own version
        assert _timeless(body) == _alone(s, VIEWS)  # the same as computed for this session alone


def test_a_new_step_and_a_student_who_moved_are_computed_again(
        computations: list[Config]) -> None:
    reg, students = _class_on_step(4)  # step 5 has another input (a minor loop)
    settings = Settings()
    for s in students:
        actions.session_figures(s, VIEWS, settings)
    assert len(computations) == 1
    lessons.go_to(reg, move=1)
    for s in students:
        actions.session_figures(s, VIEWS, settings)
    assert len(computations) == 2
    mover = students[3]
    actions.change_config(mover, lambda c: replace(c, mismatch=c.mismatch + 0.1), settings)
    mine = actions.session_figures(mover, VIEWS, settings)
    assert len(computations) == 3
    assert _timeless(mine) == _alone(mover, VIEWS)
    others = [actions.session_figures(s, VIEWS, settings) for s in students if s is not mover]
    assert len(computations) == 3  # the rest of the class still shares the step's
    assert all(b["figures"] != mine["figures"] or b["version"] != mine["version"]
               for b in others)
    # another view of the step is another outcome
    actions.session_figures(students[0], ["operators"], settings)
    assert len(computations) == 4


def test_pages_asking_at_once_wait_for_one_computation(computations: list[Config]) -> None:
    _, students = _class_on_step(3)
    settings = Settings()
    bodies: list[dict[str, Any]] = []
    start = threading.Barrier(N_STUDENTS)

    def ask(s: Session) -> None:
        start.wait()
        bodies.append(actions.session_figures(s, VIEWS, settings))

    threads = [threading.Thread(target=ask, args=(s,)) for s in students]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(bodies) == N_STUDENTS
    assert len(computations) == 1


def test_viser_tabs_on_the_step_share_one_result(computations: list[Config]) -> None:
    _, students = _class_on_step(2)
    settings = Settings()
    results = [actions.session_result(s, {"loop"}, settings) for s in students]
    assert len(computations) == 1
    assert [r.version for r in results] == [s.snapshot()[1] for s in students]
    first = results[0]
    assert all(r.y is first.y for r in results)  # one computation's arrays


def test_a_recording_session_is_never_shared() -> None:
    cfg = Config()
    assert actions._shareable(cfg, None, None)
    assert actions._shareable(replace(cfg, use_recording=True), None, None)
    assert not actions._shareable(replace(cfg, use_recording=True), object(), None)  # type: ignore[arg-type]
    assert not actions._shareable(cfg, None, object())  # type: ignore[arg-type]


def test_the_map_is_bounded_and_keeps_the_recent_keys() -> None:
    m = SharedResults(max_items=3)
    for k in "abcd":
        m.get(k, lambda k=k: k.upper())
    assert len(m) == 3 and m.computed == 4
    assert m.get("b", lambda: "again") == "B"  # kept: not computed again
    assert m.get("a", lambda: "again") == "again"  # dropped as the oldest
    assert m.get("x", lambda: None, keep=lambda o: o is not None) is None
    assert m.get("x", lambda: 1) == 1  # a refusal is not kept


def test_the_key_is_the_content() -> None:
    a, b = Config(), Config()
    assert shared.content_key("figures", a, ("loop",)) == shared.content_key(
        "figures", b, ("loop",))
    assert shared.content_key("figures", a, ("loop",)) != shared.content_key(
        "figures", replace(a, mismatch=0.1), ("loop",))
    assert shared.content_key("figures", a, ("loop",)) != shared.content_key(
        "figures", a, ("time",))
    assert shared.content_key("figures", a, ("loop",)) != shared.content_key(
        "result", a, ("loop",))
