"""A class in one run (issue 33): the teacher's web page leads "PI basics" through every
step and one push of an edited model to three web students (one on a phone) and two viser
students. Correctness only (the timings of a class of thirty are
``benchmarks/bench_class.py``'s): every student shows every step and the push, none is ever
told "You are exploring" (none moves), the teacher's page is on the step after its own
push and never reads "Your teacher", the teacher's counts are the class, and no viser
student sees the teacher's buttons."""

from __future__ import annotations

from typing import Any

from app.services.teaching.lessons import builtin_lesson, class_lesson

from .class_run import close_class, open_class, run_lesson
from .test_viser_gui import _screenshot as _viser_shot


def test_a_class_follows_every_step_and_the_push(browser: Any, live_server: dict,
                                                 shot: Any) -> None:
    url, app = live_server["url"], live_server["app"]
    teacher, students = open_class(browser, url, live_server["viser_url"], app, 3, 2)
    t = teacher[1]

    def pictures() -> None:
        shot(t, "class-teacher-after-push")
        shot(students[0].page, "class-phone-student-after-push")
        _viser_shot(students[-1].page, shot, "class-viser-student-after-push")

    try:
        run = run_lesson(url, teacher, students, settle_s=0.5, after_push=pictures)
        lesson = builtin_lesson("pi-basics")
        assert [m.label for m in run.moves] == [
            "step 1", "step 2", "push at step 2", "step 3", "step 4", "step 5", "step 6"]
        assert run.missing() == [], run.missing()
        assert run.told_exploring == [], "told they explore without moving"
        n = len(lesson.steps)
        for m in run.moves:
            what = "Pushed a model" if m.edit else f"Step {m.step} of {n} sent"
            assert m.teacher_says == f"{what} to the class: {run.expected_counts}.", m
            assert m.teacher_step == str(m.step), m  # the teacher's page is on the step
            assert "Your teacher" not in m.teacher_note, m
        assert run.expected_counts == "4 web pages and 2 3D / GUI tabs open, in 6 sessions"
        assert all((c["pages"], c["viser_tabs"], c["sessions_live"]) == (4, 2, 6)
                   for c in run.connected), run.connected
        # the viser students hold the last step's model and view (server side), and see
        # none of the teacher's buttons (their Session folder is open: they typed a name)
        last = lesson.steps[-1]
        for s in students:
            if s.kind == "viser":
                assert s.view.session.config.model == last.model
                assert s.view.figure_name == last.view
                for button in ("Teacher: push this model to every session",
                               "Teacher: who is connected?"):
                    assert not s.page.get_by_role("button", name=button).first.is_visible()
                assert s.page.get_by_role("button", name="Join / restore session"
                                          ).first.is_visible()
                assert not s.page.get_by_text("Teacher: lead a lesson").first.is_visible()
    finally:
        class_lesson(app.state.registry)._move(None)  # other journeys see no lesson
        close_class(teacher, students)
