"""The teacher's push during a lesson (issue 33, item 3): the pushed model becomes the class
step, so the students stay on it; without a lesson a push is the plain push."""

from __future__ import annotations

from typing import Any

from app.services.explore.config import SignalSpec
from app.services.session.sessions import SessionRegistry
from app.services.settings import Settings
from app.services.teaching import lessons
from app.services.teaching.events import HUB
from core.pi import PIModel


def _push_events(action: Any) -> list[dict[str, Any]]:
    """The events the hub broadcast while ``action()`` ran."""
    got: list[dict[str, Any]] = []

    def listen(ev: dict[str, Any]) -> int:
        got.append(ev)
        return 0

    HUB.add_listener(listen)
    try:
        action()
    finally:
        HUB.remove_listener(listen)
    return got


def test_a_push_during_a_lesson_becomes_the_class_step() -> None:
    reg = SessionRegistry()
    a, b = reg.create(), reg.create()
    shipped = lessons.builtin_lesson("pi-basics")
    lessons.start(reg, shipped, step=2)
    before = shipped.steps[1]
    edited = PIModel(0.9, [0.5, 1.0], [0.3, 0.2]).to_dict()
    out: list[tuple[int, int]] = []
    got = _push_events(lambda: out.append(lessons.push_to_class(
        reg, model=edited, note={"title": "a model"})))
    ((n, _),) = out
    pos = lessons.class_lesson(reg).position
    assert pos is not None and (pos.index, n) == (1, 2)
    step = pos.step
    # the step is the pushed model with the step's own input, prompt and view
    assert step.model == edited and step.preset is None
    assert (step.signal, step.prompt, step.view) == (before.signal, before.prompt, before.view)
    assert shipped.steps[1].model != edited  # the shipped lesson itself is untouched
    for s in (a, b):  # every student is on the class step (lesson.js's and viser's rule)
        assert s.config.model == step.model and s.config.signal == step.signal
    ev = next(e for e in got if e.get("lesson"))
    assert ev["edit"] is True and ev["lesson"]["model"] == edited and ev["lesson"]["step"] == 2
    # a student who explores comes back to the pushed model
    a.update(lambda c: c.with_model(PIModel(1.0, [0.5], [0.1]).to_dict()))
    lessons.return_to_step(a, reg, Settings())
    assert a.config.model == edited
    # an input pushed alone keeps the pushed model and changes the step's input
    sig = SignalSpec(kind="sine", amplitude=2.0, frequency=1.0, duration=2.0)
    lessons.push_to_class(reg, signal=sig)
    pos = lessons.class_lesson(reg).position
    assert pos is not None and pos.step.signal == sig and pos.step.model == edited
    lessons.end(reg)


def test_without_a_lesson_a_push_is_the_plain_push() -> None:
    reg = SessionRegistry()
    a = reg.create()
    edited = PIModel(0.9, [0.5], [0.3]).to_dict()
    n, _ = lessons.push_to_class(reg, model=edited)
    assert n == 1 and a.config.model == edited
    assert lessons.class_lesson(reg).position is None
