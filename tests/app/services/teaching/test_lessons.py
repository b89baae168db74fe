"""Lessons: strict reading of lesson files, the shipped lessons, the class's position."""

from __future__ import annotations

import copy
import json
import re
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.services.explore.config import Config, SignalSpec
from app.services.explore.figures import build
from app.services.explore.simulation import compute, preset_doc
from app.services.session.sessions import SessionRegistry
from app.services.settings import Settings
from app.services.teaching import lessons
from app.services.teaching.events import HUB
from app.services.teaching.lessons import LessonError, lesson_from_dict, parse_lesson
from core.base import model_from_dict
from core.pi import PIModel
from core.presets import PAPER001_EX1

GOOD: dict[str, Any] = {
    "title": "Mine",
    "steps": [
        {"title": "first", "preset": "paper001-example1", "view": "loop", "prompt": "look"},
        {"title": "second", "model": {"type": "pi", "p0": 0.5, "thresholds": [1.0, 2.0],
                                      "weights": [0.3, 0.2]},
         "input": {"amplitude": 3.0}, "mismatch": 0.2, "view": "inverse",
         "prompt": "and now?", "look_for": "the error"},
    ],
}


def _with(path: str, value: Any) -> dict[str, Any]:
    """GOOD with ``path`` (``steps.1.view``) set to ``value`` (``...`` deletes it)."""
    doc = copy.deepcopy(GOOD)
    *head, last = path.split(".")
    node: Any = doc
    for key in head:
        node = node[int(key)] if key.isdigit() else node[key]
    key: Any = int(last) if last.isdigit() else last
    if value is ...:
        del node[key]
    else:
        node[key] = value
    return doc


def test_a_good_lesson_reads_with_defaults_and_round_trips() -> None:
    lesson = lesson_from_dict(GOOD)
    first, second = lesson.steps
    assert first.model == preset_doc("paper001-example1")["model"]
    assert first.signal == SignalSpec(**preset_doc("paper001-example1")["input"])
    assert (first.look_for, first.mismatch) == ("", 0.0)
    assert second.signal == SignalSpec(amplitude=3.0)  # only the amplitude given
    assert second.model == PIModel(0.5, [1.0, 2.0], [0.3, 0.2]).to_dict()
    assert second.config(Config(use_recording=True)).use_recording is False
    again = parse_lesson(lesson.to_json())
    assert again.to_dict() == lesson.to_dict()
    assert again.to_dict()["format"] == lessons.FORMAT


def test_toml_reads_like_json() -> None:
    toml = """
title = "Mine"
[[steps]]
title = "first"
preset = "paper001-example1"
view = "loop"
prompt = "look"
[[steps]]
title = "second"
input = { amplitude = 3.0 }
mismatch = 0.2
view = "inverse"
prompt = "and now?"
look_for = "the error"
[steps.model]
type = "pi"
p0 = 0.5
thresholds = [1.0, 2.0]
weights = [0.3, 0.2]
"""
    assert parse_lesson(toml).to_dict() == lesson_from_dict(GOOD).to_dict()


@pytest.mark.parametrize(("doc", "words"), [
    (_with("steps.1.promt", "x"), ["step 2 (second)", "unknown field 'promt'", "prompt"]),
    (_with("steps.0.prompt", ...), ["step 1 (first): prompt", "missing"]),
    (_with("steps.0.prompt", "   "), ["step 1 (first): prompt is empty"]),
    (_with("steps.0.model", {"type": "pi"}), ["step 1 (first)", "either", "exactly one"]),
    (_with("steps.1.model", ...), ["step 2 (second)", "either"]),
    (_with("steps.0.preset", "paper009"), ["step 1 (first): preset 'paper009'",
                                          "paper001-example1"]),
    (_with("steps.1.view", "fit"), ["step 2 (second): view 'fit'", "closed-loop"]),
    (_with("steps.1.view", ["loop"]), ["step 2 (second): view [\"loop\"]"]),
    (_with("steps.1.mismatch", 2), ["step 2 (second): mismatch is 2", "range -0.5 to 0.5"]),
    (_with("steps.1.mismatch", True), ["step 2 (second): mismatch", "true"]),
    (_with("steps.1.input", {"samples": 20.5}), ["step 2 (second): input.samples",
                                                "whole number"]),
    (_with("steps.1.input", {"samples": 10**7}), ["step 2 (second)", "samples",
                                                 "200,000"]),
    (_with("steps.1.input", {"ampl": 1}), ["step 2 (second): input: unknown field 'ampl'",
                                          "amplitude"]),
    (_with("steps.1.input", {"kind": "square"}), ["step 2 (second)", "'square' unknown",
                                                 "staircase"]),
    (_with("steps.1.input", "loud"), ["step 2 (second): input must be an object"]),
    (_with("steps.1.model", {"type": "pi", "p0": 0.5, "thresholds": [2.0, 1.0],
                             "weights": [0.3, 0.2]}), ["step 2 (second): model", "thresholds"]),
    (_with("steps.1.model", {"type": "pi", "p0": 0.5, "thresholds": list(range(1, 500)),
                             "weights": [0.1] * 499}), ["step 2 (second)", "100"]),
    (_with("steps.1.model", {"type": "no-such"}), ["step 2 (second): model", "no-such"]),
    (_with("steps.1.model", "pi"), ["step 2 (second): model must be a model document"]),
    (_with("steps.0.title", "x" * 121), ["step 1: title has 121 characters", "120"]),
    (_with("steps.0.prompt", "a\x1b[31mred"), ["step 1 (first): prompt", "control"]),
    (_with("steps.0", "loop"), ["step 1 is not an object"]),
    (_with("steps", []), ["at least one step"]),
    (_with("steps", [GOOD["steps"][0]] * 41), ["41 steps", "at most 40"]),
    (_with("title", 7), ["the lesson's title must be text, got 7"]),
    (_with("format", "hyst-lesson/9"), ["format 'hyst-lesson/9'", "hyst-lesson/1"]),
    (_with("author", "me"), ["the lesson: unknown field 'author'"]),
    ([GOOD], ["a lesson is an object"]),
])
def test_a_wrong_field_is_named_with_its_step(doc: Any, words: list[str]) -> None:
    with pytest.raises(LessonError) as err:
        lesson_from_dict(doc)
    for w in words:
        assert w in str(err.value), (w, str(err.value))
    assert isinstance(err.value, ValueError)  # a ParameterError: 422 in the API


@pytest.mark.parametrize(("text", "words"), [
    ("", ["empty"]),
    ('{"title": "x", "steps": [}', ["not valid JSON", "line 1"]),
    ('{"title": "x", "steps": [{"title": "a", "preset": "paper001-example1", "prompt": "p",'
     ' "mismatch": NaN}]}', ["NaN", "not a number"]),
    ("title = \n", ["neither JSON", "TOML"]),
    (b"\xff\xfe{}", ["not UTF-8"]),
    ("{" + " " * lessons.MAX_LESSON_BYTES + "}", ["at most 200000"]),
])
def test_a_file_that_cannot_be_read_says_why(text: str | bytes, words: list[str]) -> None:
    with pytest.raises(LessonError) as err:
        parse_lesson(text)
    for w in words:
        assert w in str(err.value), (w, str(err.value))


def test_the_step_models_are_priced_against_the_servers_limits() -> None:
    tight = Settings(max_operators=5)
    with pytest.raises(LessonError, match="step 1 \\(first\\).*6 operators.*at most 5"):
        lesson_from_dict(GOOD, tight)


def test_the_shipped_lessons_load_and_every_step_draws_its_view() -> None:
    shipped = lessons.builtin_lessons()
    assert [x.name for x in shipped] == ["pi-basics", "inverse-compensation", "deadzone-gpi",
                                         "digitized-states", "what-a-diagnosis-finds"]
    for lesson in shipped:
        assert lessons.builtin_lesson(lesson.name) is lesson
        for step in lesson.steps:
            res = compute(step.config(), views=[step.view])
            fig = build(step.view, res).to_dict()
            assert fig["data"], (lesson.name, step.title)
            assert not res.messages, (lesson.name, step.title, res.messages)
    with pytest.raises(LessonError, match="pi-basics"):
        lessons.builtin_lesson("nope")


def test_pi_basics_says_what_the_papers_print() -> None:
    """The texts' numbers are the model's: paper 001 Example 1's slopes and loop width."""
    pi_basics = lessons.builtin_lesson("pi-basics")
    p0, r, p = PAPER001_EX1
    ex1 = PIModel(p0, np.array(r), np.array(p))
    assert pi_basics.steps[0].model == ex1.to_dict()
    loading = next(s for s in pi_basics.steps if s.view == "loading")
    said = [float(x) for x in re.findall(r"\d\.\d+", loading.look_for.split("(")[0])]
    np.testing.assert_allclose(said, ex1.slopes, atol=5e-3)
    assert f"{ex1.max_loop_width:.3f}" in loading.look_for
    minor = next(s for s in pi_basics.steps if "minor" in s.title.lower())
    moving = [ri for ri in r if 2 * ri < 2 * minor.signal.amplitude]
    assert len(moving) == 3 and "operators 1 to 3" in minor.look_for


def test_the_inverse_lesson_says_the_error_it_shows() -> None:
    step = lessons.builtin_lesson("inverse-compensation").steps[2]
    title = build("inverse", compute(step.config(), views=["inverse"])).to_dict()["layout"]
    rms = float(re.search(r"RMS error ([\d.e-]+)", title["title"]["text"]).group(1))
    assert f"about {rms:.2f}" in step.look_for


def test_a_step_from_the_current_state() -> None:
    cfg = Config(model=preset_doc("paper001-example4")["model"], mismatch=0.1)
    step = lessons.step_from_config(cfg, "inverse", "dead zones", "what now?")
    assert (step.preset, step.mismatch, step.view) == ("paper001-example4", 0.1, "inverse")
    assert step.to_dict()["preset"] == "paper001-example4" and "model" not in step.to_dict()
    changed = cfg.with_model({**PIModel(0.7, [1.0], [0.5]).to_dict()})
    assert lessons.step_from_config(changed, "loop", "", "").to_dict()["model"]["p0"] == 0.7
    with pytest.raises(LessonError, match="fit view cannot be a step"):
        lessons.step_from_config(cfg, "fit", "x", "y")


def test_the_class_moves_step_by_step_and_a_student_returns() -> None:
    reg = SessionRegistry()
    a, b = reg.create(), reg.create()
    lesson = lesson_from_dict(GOOD)
    seen: list[Any] = []
    cl = lessons.class_lesson(reg)
    cl.add_listener(seen.append)
    assert cl.position is None and lessons.class_lesson(SessionRegistry()) is not cl
    before = HUB.newest_id()
    pos, n, _ = lessons.start(reg, lesson)
    assert (pos.index, n) == (0, 2) and a.config.model == lesson.steps[0].model
    assert HUB.newest_id() == before + 1  # the teacher's push: one event
    pos, _, _ = lessons.go_to(reg, move=1)
    for s in (a, b):
        assert s.config.model == lesson.steps[1].model
        assert (s.config.mismatch, s.config.signal.amplitude) == (0.2, 3.0)
    with pytest.raises(LessonError, match="steps 1 to 2"):
        lessons.go_to(reg, move=1)
    # student a explores, then returns to the class step; b is not touched
    a.update(lambda c: c.with_model(PIModel(1.0, [0.5], [0.1]).to_dict()))
    vb = b.version
    lessons.return_to_step(a, reg, Settings())
    assert a.config.model == lesson.steps[1].model and b.version == vb
    assert [p.index if p else None for p in seen] == [0, 1]
    lessons.end(reg)
    assert cl.position is None and seen[-1] is None
    assert a.config.model == lesson.steps[1].model  # the sessions keep what they have
    with pytest.raises(LessonError, match="no lesson is running"):
        lessons.return_to_step(a, reg, Settings())
    with pytest.raises(LessonError, match="start one"):
        lessons.go_to(reg, step=1)


def test_the_push_event_carries_the_step_as_text() -> None:
    reg = SessionRegistry()
    reg.create()
    evil = _with("steps.0.prompt", "<img src=x onerror=alert(1)>")
    pos, _, _ = lessons.start(reg, lesson_from_dict(evil), step=1)
    event = pos.to_dict()
    assert event["prompt"] == "<img src=x onerror=alert(1)>"  # kept as data, drawn as text
    assert json.loads(json.dumps(event)) == event
    assert (event["step"], event["steps"]) == (1, 2)
    lessons.end(reg)


def test_every_shipped_model_is_a_registered_model() -> None:
    for lesson in lessons.builtin_lessons():
        for step in lesson.steps:
            assert model_from_dict(step.model).to_dict() == step.model


def test_a_restarted_server_starts_where_the_class_was(tmp_path: Any) -> None:
    from app.services.storage.store import SessionStore

    path = tmp_path / "sessions.sqlite3"
    store = SessionStore(path)
    reg = SessionRegistry(store=store)
    reg.create()
    shipped = lessons.builtin_lesson("pi-basics")
    lessons.start(reg, shipped, step=4)
    store.close()  # the server is gone; its sessions and the class's step are on disk
    again = SessionRegistry(store=SessionStore(path))
    pos = lessons.class_lesson(again).position
    assert pos is not None and (pos.index, pos.lesson.name) == (3, "pi-basics")
    assert pos.lesson.to_dict() == shipped.to_dict()
    lessons.end(again)
    again.store.close()
    assert lessons.class_lesson(SessionRegistry(store=SessionStore(path))).position is None


def test_a_damaged_stored_lesson_is_not_restored(tmp_path: Any,
                                                 caplog: pytest.LogCaptureFixture) -> None:
    from app.services.storage.store import SessionStore

    store = SessionStore(tmp_path / "sessions.sqlite3")
    store.put_class_state("lesson", '{"lesson": {"title": "x", "steps": []}, "index": 0}')
    assert lessons.ClassLesson(store).position is None
    assert "not restored" in caplog.text and "at least one step" in caplog.text
    store.put_class_state("lesson", "not json")
    assert lessons.ClassLesson(store).position is None


_JSON = st.recursive(
    st.none() | st.booleans() | st.integers(-10**20, 10**20) | st.floats() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner,
                                                                max_size=4), max_leaves=20)


@settings(max_examples=300, deadline=None)
@given(field=st.sampled_from(["title", "preset", "input", "mismatch", "view", "prompt",
                              "look_for", "model"]), value=_JSON,
       kind=st.sampled_from(["pi", "chain", "gpi-deadzone", "digitized", "creep", "delay"]))
def test_any_value_in_any_field_is_a_lesson_error_or_a_lesson(field: str, value: Any,
                                                              kind: str) -> None:
    """A lesson file is hostile data: whatever a field holds, the reader answers a lesson or
    a LessonError (a 422), never another exception (a 500)."""
    doc = copy.deepcopy(GOOD)
    if field == "model":
        doc["steps"][0].pop("preset")
        value = {"type": kind, **(value if isinstance(value, dict) else {"p0": value})}
    doc["steps"][0][field] = value
    try:
        lesson_from_dict(doc)
    except LessonError:
        pass


def test_moves_never_interleave(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two quick clicks on Next: the sessions end at the step the class is at, even when
    the first push is the slower one (without the move lock it lands last)."""
    import threading
    import time

    reg = SessionRegistry()
    s = reg.create()
    lesson = lessons.builtin_lesson("inverse-compensation")  # steps 2 and 3 differ
    lessons.start(reg, lesson)
    push = lessons.teacher.push

    def slow_first(registry: Any, **kw: Any) -> Any:
        if kw["note"]["lesson"]["step"] == 2:
            time.sleep(0.3)
        return push(registry, **kw)

    monkeypatch.setattr(lessons.teacher, "push", slow_first)
    first = threading.Thread(target=lambda: lessons.go_to(reg, move=1))
    first.start()
    time.sleep(0.05)
    lessons.go_to(reg, move=1)
    first.join()
    pos = lessons.class_lesson(reg).position
    assert pos is not None and pos.index == 2
    want = lesson.steps[2]
    assert want.model != lesson.steps[1].model
    assert (s.config.model, s.config.mismatch) == (want.model, want.mismatch)


def _run(step: Any) -> Any:
    return compute(step.config(), views=[step.view])


def test_the_diagnosis_lesson_shows_what_it_says() -> None:
    """Each effect step does to the run what its text says (against the PI alone)."""
    from dataclasses import replace

    steps = lessons.builtin_lesson("what-a-diagnosis-finds").steps
    pi, lag, creep, asym = steps[0], steps[1], steps[2], steps[3]

    def gap(res: Any) -> float:  # the loop's vertical opening at u = 0, second period
        half = res.u.size // 2
        u, y = res.u[half:], res.y[half:]
        rising = np.diff(u, prepend=u[0]) > 0
        near = np.abs(u) < 0.05
        return float(y[near & ~rising].mean() - y[near & rising].mean())

    slow = replace(lag, signal=replace(lag.signal, frequency=1.0))
    assert "5 Hz" in lag.prompt and lag.signal.frequency == 5.0
    assert gap(_run(lag)) > 1.5 * gap(_run(slow)) > 1.5 * gap(_run(pi)) * 0.9
    # creep: after each step of the staircase the output moves on by about a fifth
    res = _run(creep)
    jumps = np.flatnonzero(np.abs(np.diff(res.u)) > 1e-9)
    ratios = [(res.y[k] - res.y[i + 1]) / (res.y[i + 1] - res.y[i])
              for i, k in zip(jumps[:8], jumps[1:9], strict=True)]
    assert "a fifth" in creep.look_for and np.all(np.abs(np.array(ratios) - 0.2) < 0.05)
    # asymmetry: the top of the loop is stretched, the bottom squeezed
    res = _run(asym)
    assert res.y.max() > 1.3 * -res.y.min()


def test_the_closed_loop_step_says_the_errors_it_shows() -> None:
    step = lessons.builtin_lesson("inverse-compensation").steps[3]
    title = build("closed-loop", _run(step)).to_dict()["layout"]["title"]["text"]
    rms = [float(x) for x in re.findall(r"RMS ([\d.e-]+)", title)]
    assert len(rms) == 3
    for value in rms:
        assert f"about {value:.2g}" in step.look_for or f"about {value:.1g}" in step.look_for
