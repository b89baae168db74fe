"""The viser lesson panel without a browser: the class step, exploring, the teacher's moves."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from types import SimpleNamespace
from typing import Any

import pytest

from app.gui.controller import SessionView
from app.gui.layout import TITLES
from app.services.session.sessions import SessionRegistry
from app.services.settings import Settings
from app.services.teaching import lessons
from core.pi import PIModel
from tests.app.gui.test_gui_headless import server  # noqa: F401 - the viser server fixture

TOKEN = "s3cret"


@pytest.fixture
def view(server: Any) -> Iterator[SessionView]:  # noqa: F811 - the fixture imported above
    reg = SessionRegistry()
    sent: dict[str, list[Any]] = {"downloads": [], "toasts": []}
    v = SessionView(server.gui, reg, reg.create(), Settings(teacher_token=TOKEN),
                    notify=lambda *a: sent["toasts"].append(a),
                    download=lambda n, b: sent["downloads"].append((n, b)))
    v.downloads, v.toasts = sent["downloads"], sent["toasts"]  # type: ignore[attr-defined]
    assert v.worker.wait_idle(30)
    yield v
    lessons.end(reg)
    v.close()


def _click(handle: Any) -> None:
    for cb in handle._impl.update_cb:  # on_click callbacks (viser 1.1)
        cb(SimpleNamespace(client=None, target=handle))


def test_teacher_leads_the_class_from_the_gui(view: SessionView) -> None:
    panel = view.lesson
    other = view.registry.create()
    assert panel.md.content == "*No lesson is running.*" and panel.back_btn.disabled
    set_pick = panel.choices["Inverse compensation"]
    panel.pick.value = set_pick.title
    _click(panel.start_btn)  # no token typed: refused, nothing changes
    assert "wrong teacher token" in panel.msg.content and panel.cls.position is None
    view.ui.teacher_token.value = TOKEN
    _click(panel.start_btn)
    assert panel.cls.position is not None and panel.cls.position.index == 0
    assert view.ui.teacher_token.value == ""  # not left on a projector
    _click(panel.next_btn)  # on loopback the tab keeps the right token
    step = set_pick.steps[1]
    assert other.config.model == step.model and view.session.config.model == step.model
    assert view.ui.view_dd.value == TITLES[step.view]
    assert view.worker.wait_idle(30) and view.shown_figure == step.view
    assert "step 2 of 4" in panel.md.content and "on the class step" in panel.md.content
    assert view.toasts[-1][:2] == ("Lesson", f"the class is at step 2 of 4: {step.title}")
    assert not panel.prev_btn.disabled and not panel.back_btn.disabled
    # the student explores, then comes back
    view.session.update(lambda c: c.with_model(PIModel(1.0, [0.5], [0.2]).to_dict()))
    assert "exploring" in panel.md.content
    _click(panel.back_btn)
    assert view.session.config.model == step.model and "on the class step" in panel.md.content
    _click(panel.end_btn)
    assert panel.cls.position is None and panel.md.content == "*No lesson is running.*"


def test_lesson_texts_are_shown_as_text(view: SessionView) -> None:
    evil = {"title": "<b>x</b>", "steps": [{
        "title": "[link](http://example.com)", "preset": "paper001-example1",
        "prompt": "<img src=x onerror=alert(1)>", "look_for": "**bold**"}]}
    lessons.start(view.registry, lessons.lesson_from_dict(evil))
    md = view.lesson.md.content
    assert "<img" not in md and "&lt;img" in md and "\\[link\\]" in md and "\\*\\*bold" in md


def test_a_lesson_made_from_the_screen_downloads_and_loads_again(view: SessionView) -> None:
    panel = view.lesson
    panel.step_title.value = "my loop"
    panel.prompt.value = "what do you see?"
    lesson = panel.add_step()
    view.session.update(lambda c: c.with_model(PIModel(0.5, [1.0], [0.4]).to_dict()))
    with view._quiet():
        view.ui.view_dd.value = TITLES["inverse"]
    lesson = panel.add_step()
    assert [s.view for s in lesson.steps] == ["loop", "inverse"]
    assert lesson.steps[0].preset == "paper001-example1" and lesson.steps[1].preset is None
    assert panel.pick.value == "my lesson (2 steps)"
    _click(panel.download_btn)
    name, payload = view.downloads[-1]
    assert name.endswith(".json")
    again = lessons.parse_lesson(payload)
    assert again.to_dict() == lesson.to_dict()
    panel._uploaded(SimpleNamespace(target=SimpleNamespace(value=SimpleNamespace(
        content=payload, name="mine.json"))))
    assert panel.pick.value.startswith("file: My lesson (2 steps)")
    bad = json.loads(payload)
    bad["steps"][1]["view"] = "fit"
    panel._uploaded(SimpleNamespace(target=SimpleNamespace(value=SimpleNamespace(
        content=json.dumps(bad).encode(), name="bad.json"))))
    assert "not loaded" in panel.msg.content and "step 2" in panel.msg.content


def test_no_token_on_the_server_says_how_to_give_one(server: Any) -> None:  # noqa: F811
    reg = SessionRegistry()
    v = SessionView(server.gui, reg, reg.create(), Settings())
    try:
        v.ui.teacher_token.value = "anything"
        _click(v.lesson.start_btn)
        assert "--teacher-token-file" in v.lesson.msg.content
        assert v.lesson.cls.position is None
    finally:
        v.close()


class _Said:
    """Stands for a markdown handle and keeps every text given to it."""

    def __init__(self, handle: Any) -> None:
        object.__setattr__(self, "handle", handle)
        object.__setattr__(self, "said", [])

    def __getattr__(self, name: str) -> Any:
        return getattr(self.handle, name)

    def __setattr__(self, name: str, value: Any) -> None:
        if name == "content":
            self.said.append(value)
        setattr(self.handle, name, value)


def test_a_move_never_tells_a_student_who_did_not_move_that_they_explore(
        view: SessionView) -> None:
    """Every text the Lesson folder shows while the class starts, moves, and gets the
    teacher's push says the tab is on the class step: the tab is told of the move after the
    push has given its session the step (told before, it compared its old step's model with
    the new step and said "You are exploring" until the push reached it)."""
    panel = view.lesson
    said = _Said(panel.md)
    panel.md = said  # type: ignore[assignment]
    lesson = lessons.builtin_lesson("pi-basics")
    lessons.start(view.registry, lesson)
    for _ in range(len(lesson.steps) - 1):
        lessons.go_to(view.registry, move=1)
    lessons.push_to_class(view.registry, model=PIModel(1.1, [0.5], [0.3]).to_dict())
    steps = [t for t in said.said if "step " in t]
    assert len(steps) >= len(lesson.steps) + 1, said.said
    assert [t for t in steps if "exploring" in t] == []
    assert "on the class step" in said.said[-1]
    # a student who does move is told
    view.session.update(lambda c: c.with_model(PIModel(1.0, [0.5], [0.2]).to_dict()))
    assert "You are exploring" in said.said[-1]


def test_students_never_see_the_teachers_buttons(view: SessionView) -> None:
    """The push, *Who is connected?* and the lesson's teacher folder are hidden in a new
    tab and stay hidden for a wrong token; the right one shows them."""
    teacher = (view.ui.push_btn, view.ui.who_btn, view.lesson.teacher_folder)
    assert [h.visible for h in teacher] == [False, False, False]
    view.ui.teacher_token.value = "not-" + TOKEN
    assert [h.visible for h in teacher] == [False, False, False]
    view.ui.teacher_token.value = TOKEN
    assert [h.visible for h in teacher] == [True, True, True]
    _click(view.lesson.start_btn)  # and they work
    assert view.lesson.cls.position is not None


def test_a_moves_text_leaves_before_its_plot_and_its_toast_after(server: Any) -> None:  # noqa: F811
    """A lesson's move: the tab's queued messages are flushed with the step's text in the
    Lesson folder while the plot still shows the old step, the new plot is set at least
    ``TEXT_FIRST_S`` later, and the move's one toast comes after that plot (issue 33: in a
    class of thirty a viser tab painted the step's text only after plotly's redraw and the
    toast's transition; before this, no flush and the toast came first)."""
    from app.gui import controller

    reg = SessionRegistry()
    log: list[tuple[str, float, str, str]] = []
    holder: dict[str, SessionView] = {}

    def seen(what: str) -> None:
        v = holder.get("v")
        if v is not None:
            log.append((what, time.monotonic(), v.lesson.md.content,
                        v.ui.plot._plotly_json_str))

    v = SessionView(server.gui, reg, reg.create(), Settings(),
                    notify=lambda *a: seen("toast"), flush=lambda: seen("flush"))
    holder["v"] = v
    try:
        lesson = lessons.builtin_lesson("pi-basics")
        lessons.start(reg, lesson)
        assert v.worker.wait_idle(30)
        old = v.ui.plot._plotly_json_str
        log.clear()
        lessons.go_to(reg, move=1)
        assert v.worker.wait_idle(30)
        kinds = [x[0] for x in log]
        assert kinds == ["flush", "toast"], kinds
        flush, toast = log
        assert "step 2 of" in flush[2] and "on the class step" in flush[2]
        assert flush[3] == old  # the plot not yet sent with the text
        assert toast[3] != old  # the step's plot was sent before the toast
        assert toast[1] - flush[1] >= controller.TEXT_FIRST_S
    finally:
        lessons.end(reg)
        v.close()


def test_a_moves_text_leaves_before_the_steps_sliders(server: Any) -> None:  # noqa: F811
    """*PI basics* step 6 adds the initial play outputs to the model: the tab's flush with
    the step's text comes before the new sliders are made (they followed in the same batch:
    the text was painted only once the tab had mounted them), and the groups that stay (p0,
    thresholds, weights) keep their sliders: only the new group is added (every slider was
    removed and added again: 16 removed, 23 added), and going back removes only it."""
    reg = SessionRegistry()
    log: list[tuple[str, set[str]]] = []
    holder: dict[str, SessionView] = {}

    def seen(what: str) -> None:
        v = holder.get("v")
        if v is not None:
            log.append((what, set(v.ui.param_sliders)))

    v = SessionView(server.gui, reg, reg.create(), Settings(), notify=lambda *a: None,
                    flush=lambda: seen("flush"))
    holder["v"] = v
    try:
        lesson = lessons.builtin_lesson("pi-basics")
        lessons.start(reg, lesson, step=5)
        assert v.worker.wait_idle(30)
        before = dict(v.ui.param_sliders)
        assert not any(p.startswith("state0") for p in before)
        log.clear()
        lessons.go_to(reg, move=1)  # step 6: Example 1 with M0 = 1
        assert v.worker.wait_idle(30)
        assert log and log[0][0] == "flush" and log[0][1] == set(before), log
        after = v.ui.param_sliders
        assert sum(p.startswith("state0") for p in after) == 6
        assert all(after[p] is h for p, h in before.items()), "a kept slider was replaced"
        assert after["state0[0]"].value == pytest.approx(1.0)
        lessons.go_to(reg, move=-1)
        assert v.worker.wait_idle(30)
        assert set(v.ui.param_sliders) == set(before)
        assert all(v.ui.param_sliders[p] is h for p, h in before.items())
    finally:
        lessons.end(reg)
        v.close()



def _pi_basics_messages(viser_server: Any, then: Callable[[SessionView], None]
                        ) -> tuple[list[list[Any]], SessionView, dict[str, set[str]]]:
    """The viser messages one student tab is sent per move of *PI basics* (steps 1-6:
    the start, then five Next), the tab (after ``then(tab)``, before it is closed) and the
    uuids of the elements it does not show."""
    ws = viser_server._websock_server
    log: list[Any] = []
    real = ws.queue_message
    ws.queue_message = lambda m: (log.append(m), real(m))
    reg = SessionRegistry()
    v = SessionView(viser_server.gui, reg, reg.create(), Settings(), notify=lambda *a: None,
                    scene=viser_server.scene)
    moves: list[list[Any]] = []
    try:
        assert v.worker.wait_idle(30)
        hidden = {"sheet's View": {v.ui.view_dropdowns[1]._impl.uuid},
                  "teacher's buttons": {h._impl.uuid for h in (
                      v.lesson.prev_btn, v.lesson.next_btn, v.lesson.end_btn)}}
        assert v.ui.view_dd is v.ui.view_dropdowns[0]  # the panel's, not the sheet's
        lesson = lessons.builtin_lesson("pi-basics")
        for k in range(len(lesson.steps)):
            log.clear()
            if k == 0:
                lessons.start(reg, lesson)
            else:
                lessons.go_to(reg, move=1)
            assert v.worker.wait_idle(30)
            assert f"step {k + 1} of 6" in v.lesson.md.content
            moves.append(list(log))
        then(v)
    finally:
        ws.queue_message = real
        lessons.end(reg)
        v.close()
    return moves, v, hidden


def test_a_students_tab_gets_nothing_for_the_view_dropdown_it_does_not_show(
        server: Any) -> None:  # noqa: F811
    """The phone sheet's *View* dropdown, hidden on a wide screen, was set at every move
    with the shown one (one more message per move to every tab, issue 33); it takes the
    view when it is shown."""
    def narrow(v: SessionView) -> None:
        v.set_narrow(True)
        assert v.ui.view_dd.value == TITLES[lessons.builtin_lesson("pi-basics").steps[-1].view]

    moves, _, hidden = _pi_basics_messages(server, narrow)
    sent = [[m for m in ms if getattr(m, "uuid", None) in hidden["sheet's View"]]
            for ms in moves]
    assert not any(sent), sent  # main b191a9f: one at each of steps 2-6


def test_a_students_tab_gets_nothing_for_the_teachers_buttons(server: Any) -> None:  # noqa: F811
    """A student's tab never shows the teacher's Previous, Next and End: they were set at
    the start (3 messages) and at steps 2 and 6; they are set when the teacher's folder is
    shown, as the class step allows them."""
    def teacher(v: SessionView) -> None:
        v.show_teacher()
        assert not v.lesson.prev_btn.disabled and v.lesson.next_btn.disabled
        assert not v.lesson.end_btn.disabled

    moves, _, hidden = _pi_basics_messages(server, teacher)
    sent = [[m for m in ms if getattr(m, "uuid", None) in hidden["teacher's buttons"]]
            for ms in moves]
    assert not any(sent), sent


def test_the_state_graph_is_hidden_and_shown_with_one_message(server: Any) -> None:  # noqa: F811
    """Step 5 (no digitized view) hides the state graph and step 6 shows it again: one
    message each (its parent frame), not one per node (5 and 5 on main ``b191a9f``). Per
    move a student's tab got 5, 6, 5, 5, 13, 24 messages on main (58), 3, 4, 4, 4, 8, 18
    (41) with the three changes."""
    from viser import _messages as M

    moves, _, _ = _pi_basics_messages(server, lambda v: None)
    vis = [[m.name for m in ms if isinstance(m, M.SetSceneNodeVisibilityMessage)]
           for ms in moves]
    assert vis == [[], [], [], [], ["/states"], ["/states"]], vis
    assert [len(ms) for ms in moves] == [3, 4, 4, 4, 8, 18], [len(ms) for ms in moves]
