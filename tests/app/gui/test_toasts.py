"""A tab's toasts without a browser: one per title, changed in place while on show."""

from __future__ import annotations

from typing import Any

from app.gui.toasts import AUTO_CLOSE_S, CHANGE_WITHIN_S, Toasts


class _Handle:
    def __init__(self, log: list[tuple[str, Any]], title: str, body: str, **kw: Any) -> None:
        object.__setattr__(self, "_log", log)
        object.__setattr__(self, "title", title)
        object.__setattr__(self, "body", body)
        object.__setattr__(self, "auto_close_seconds", kw["auto_close_seconds"])
        object.__setattr__(self, "color", kw["color"])
        log.append(("show", body))

    def __setattr__(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)
        self._log.append((name, value))

    def remove(self) -> None:
        self._log.append(("remove", self.body))


def _toasts() -> tuple[Toasts, list[tuple[str, Any]], list[float]]:
    log: list[tuple[str, Any]] = []
    now = [100.0]
    return Toasts(lambda *a, **kw: _Handle(log, *a, **kw), clock=lambda: now[0]), log, now


def test_a_lessons_moves_change_one_toast_in_place() -> None:
    """Six moves 1.5 s apart: one toast shown, then changed five times (main: six shown,
    five removed); each change gives it another of the two durations, so the browser
    starts its close timer again."""
    toasts, log, now = _toasts()
    for k in range(1, 7):
        toasts("Lesson", f"the class is at step {k} of 6", False)
        now[0] += 1.5
    assert [x for x in log if x[0] in ("show", "remove")] == [
        ("show", "the class is at step 1 of 6")]
    assert [x[1] for x in log if x[0] == "body"] == [
        f"the class is at step {k} of 6" for k in range(2, 7)]
    durations = [x[1] for x in log if x[0] == "auto_close_seconds"]
    assert len(durations) == 5
    assert durations[0] != durations[1] and durations == durations[:2] * 2 + durations[:1]
    assert all(abs(d - AUTO_CLOSE_S) < 0.01 for d in durations)


def test_a_toast_that_may_have_closed_is_shown_anew() -> None:
    toasts, log, now = _toasts()
    toasts("Lesson", "step 1", False)
    now[0] += CHANGE_WITHIN_S + 0.1  # closing or closed in the browser
    toasts("Lesson", "step 2", False)
    assert log == [("show", "step 1"), ("remove", "step 1"), ("show", "step 2")]


def test_titles_and_kinds_keep_their_own_toasts() -> None:
    """Another title is another toast; an error of the same title replaces the notice
    (its colour is its own)."""
    toasts, log, now = _toasts()
    toasts("Lesson", "step 1", False)
    toasts("Your teacher pushed a change", "step 2", False)
    toasts("Lesson", "failed", True)
    assert log == [("show", "step 1"), ("show", "step 2"), ("remove", "step 1"),
                   ("show", "failed")]
