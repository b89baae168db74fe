"""The viser GUI's lesson panel: the class step for everyone, the teacher's lesson controls.

A :class:`LessonPanel` belongs to one tab's :class:`~app.gui.controller.SessionView`. It
shows where the class is (:func:`app.services.teaching.lessons.class_lesson`: the lesson, the step,
its prompt and what to look for) and whether this tab is on the class step or exploring,
with a button back to the class step. The teacher (with the teacher token, under the rule
of the GUI's push: needed also on loopback) starts a lesson, moves the class and ends it
from here as from the web page; a lesson file can be loaded, and a lesson made from what
is on screen ("Add this view as a step") and downloaded. Every text of a lesson goes
through :func:`~app.gui.text.md_text`.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Any

from app.services.errors import ParameterError
from app.services.explore.config import Config
from app.services.session.sessions import Session
from app.services.teaching import lessons
from app.services.teaching.events import HUB

from .layout import TITLES, set_value
from .text import md_text

if TYPE_CHECKING:
    from .controller import SessionView

__all__ = ["LessonPanel"]

#: Steps a lesson made in the GUI may hold (the lesson file's limit).
MAX_DRAFT = lessons.MAX_STEPS


class LessonPanel:
    """The *Lesson* folder of one tab, following the class's lesson.

    Parameters
    ----------
    view : SessionView
        The tab (its GUI, session, registry, settings, toasts and downloads).
    """

    def __init__(self, view: SessionView) -> None:
        self.view = view
        self.cls = lessons.class_lesson(view.registry)
        self.choices: dict[str, lessons.Lesson] = {
            x.title: x for x in lessons.builtin_lessons()}
        self.draft: list[lessons.Step] = []
        self._session: Session | None = None
        self._last: lessons.Position | None = None  # the class step last shown
        # a move's toast, sent by the render after the move's text and plot (``_due``),
        # and the last move toasted so (its tell does not toast again)
        self._toast_lock = threading.Lock()
        self._due: lessons.Position | None = None
        self._toasted: lessons.Position | None = None
        g = view.ui.gui
        order = getattr(view.ui.code_md, "order", None)
        with g.add_folder("Lesson", order=None if order is None else order + 0.5) as self.folder:
            self.md = g.add_markdown("*No lesson is running.*")
            self.back_btn = g.add_button("Back to the class step", disabled=True,
                                         hint="give this tab the class's step again (model, "
                                              "input, view) after exploring")
            # shown once the tab has the teacher token (SessionView.show_teacher)
            with g.add_folder("Teacher: lead a lesson", expand_by_default=False,
                              visible=False) as self.teacher_folder:
                g.add_markdown("*Every step gives each student its model, input and view.*")
                titles = tuple(self.choices)
                self.pick = g.add_dropdown("Lesson", titles, initial_value=titles[0])
                self.start_btn = g.add_button("Start lesson", hint="send the lesson's first "
                                              "step to every student (teacher token)")
                self.prev_btn = g.add_button("◀ Previous step", disabled=True,
                                             hint="move the class back one step")
                self.next_btn = g.add_button("Next step ▶", disabled=True,
                                             hint="move the class on to the next step")
                self.end_btn = g.add_button("End lesson", disabled=True,
                                            hint="every session keeps the model it has")
                self.upload = g.add_upload_button("Load a lesson file (JSON or TOML)",
                                                  mime_type="*/*")
                with g.add_folder("Make a lesson", expand_by_default=False):
                    self.lesson_title = g.add_text("Lesson title", initial_value="My lesson")
                    self.step_title = g.add_text("Step title", initial_value="")
                    self.prompt = g.add_text("Prompt", initial_value="", multiline=True)
                    self.look_for = g.add_text("Look for", initial_value="", multiline=True)
                    self.add_btn = g.add_button("Add this view as a step",
                                                hint="this tab's model, input, mismatch and "
                                                     "view, with the texts above")
                    self.download_btn = g.add_button("Download my lesson (JSON)",
                                                     hint="the lesson file, to load again")
                self.msg = g.add_markdown("")
        guard = view._guarded
        self.back_btn.on_click(guard(lambda ev: self.back()))
        self.start_btn.on_click(guard(lambda ev: self._teach(self._start)))
        self.prev_btn.on_click(guard(lambda ev: self._teach(lambda: lessons.go_to(
            view.registry, move=-1))))
        self.next_btn.on_click(guard(lambda ev: self._teach(lambda: lessons.go_to(
            view.registry, move=1))))
        self.end_btn.on_click(guard(lambda ev: self._teach(self._end)))
        self.upload.on_upload(guard(self._uploaded))
        self.add_btn.on_click(guard(lambda ev: self.add_step()))
        self.download_btn.on_click(guard(self._download))
        self.follow(view.session)
        self.cls.add_listener(self._moved)
        self._moved(self.cls.position, switch=False)

    # ------------------------------------------------------------------ everyone
    def follow(self, session: Session) -> None:
        """Watch ``session`` (the tab's, after a join) for the on-step / exploring note."""
        if self._session is not None:
            self._session.remove_listener(self._changed)
        self._session = session
        session.add_listener(self._changed)
        self._show(self.cls.position)

    def _changed(self, session: Session, config: Config, version: int) -> None:
        self._show(self.cls.position, config)

    def on_step(self, config: Config | None = None) -> bool:
        """Whether the tab's model, input and mismatch are the class step's."""
        pos = self.cls.position
        if pos is None:
            return False
        cfg = config if config is not None else self.view.session.snapshot()[0]
        s = pos.step
        return (not cfg.use_recording and cfg.model == s.model and cfg.signal == s.signal
                and cfg.mismatch == s.mismatch)

    def _moved(self, pos: lessons.Position | None, switch: bool = True) -> None:
        last, self._last = self._last, pos
        # the teacher's push during a lesson changes the class step in place: the push's
        # own notice says so, and the tab keeps its view
        edit = (pos is not None and last is not None and pos.index == last.index
                and pos.lesson.title == last.lesson.title)
        if switch and not edit:  # a move of the class, not this tab opening
            if pos is not None:
                self._show_view(pos.step.view)
                with self._toast_lock:  # not when the move's render toasts (or did)
                    mine = pos is not self._due and pos is not self._toasted
                if mine:
                    self._toast_move(pos)
            else:
                self.view._toast("Lesson", "the teacher ended the lesson; this tab keeps its "
                                 "model and input")
        self._show(pos)

    def _toast_move(self, pos: lessons.Position) -> None:
        self.view._toast("Lesson", f"the class is at step {pos.index + 1} of "
                         f"{len(pos.lesson.steps)}: {pos.step.title}")

    def toast_due(self) -> None:
        """The toast of a move taken with its push (:meth:`take_step_view`), sent by the
        tab's render once the step's text and plot are sent: its transition (Mantine's,
        ~0.1 s of a viser tab's main thread) no longer comes before them."""
        with self._toast_lock:
            pos, self._due = self._due, None
            if pos is None:
                return
            self._toasted = pos
        self._toast_move(pos)

    def _teacher_buttons(self, pos: lessons.Position | None) -> None:
        """The teacher's Previous, Next and End as the class step ``pos`` allows them."""
        at = pos is not None
        self.prev_btn.disabled = not at or pos.index == 0
        self.next_btn.disabled = not at or pos.index + 1 >= len(pos.lesson.steps)
        self.end_btn.disabled = not at

    def show_teacher(self) -> None:
        """Show the teacher's folder, its buttons set for the class step (a student's tab
        is not sent them: each move set one or three hidden buttons in every tab)."""
        self.teacher_folder.visible = True  # first: a move from now on sets the buttons too
        self._teacher_buttons(self.cls.position)

    def _show(self, pos: lessons.Position | None, config: Config | None = None) -> None:
        self.back_btn.disabled = pos is None
        if self.teacher_folder.visible:  # a student's tab is not sent buttons it never shows
            self._teacher_buttons(pos)
        if pos is None:
            self.md.content = "*No lesson is running.*"
            return
        s = pos.step
        here = self.on_step(config)
        parts = [f"**{md_text(pos.lesson.title)}** · step {pos.index + 1} of "
                 f"{len(pos.lesson.steps)}: **{md_text(s.title)}**", md_text(s.prompt)]
        if s.look_for:
            parts.append(f"*Look for:* {md_text(s.look_for)}")
        parts.append("**You are on the class step.**" if here else
                     "**You are exploring:** your model or input differs from the class "
                     "step.")
        self.md.content = "\n\n".join(parts)

    def take_step_view(self, config: Config) -> bool:
        """The class's move reaching the tab's session (the push, before this panel is
        told of the move): the new step's view is chosen now, quietly, so the render the
        new model asks for draws the step's view. Before, the tab drew the old step's view
        with the new model, then the new view: two plots per move in each tab (issue 33,
        ten viser tabs of a class of thirty). The step's text is set here too, before that
        render, and the move's toast left to the render's end (:meth:`toast_due`).
        Returns whether this was a move of the class (the caller flushes the text)."""
        pos, last = self.cls.position, self._last
        if pos is None or pos is last or not self.on_step(config):
            return False
        if last is not None and pos.index == last.index and pos.lesson.title == last.lesson.title:
            return False  # the teacher's push of an edited step keeps the tab's view
        self._set_view(pos.step.view)
        self._show(pos, config)
        with self._toast_lock:
            if pos is not self._toasted:
                self._due = pos
        return True

    def _set_view(self, name: str) -> bool:
        """The shown *View* dropdown to ``name``, quietly; whether that changed the view
        (the hidden one takes it when it is shown, :meth:`SessionView.set_narrow`: setting
        both sent every tab a second message per move for a dropdown it does not show)."""
        v = self.view
        if v.ui.figure_name == name:
            return False
        with v._quiet():
            set_value(v.ui.view_dd, TITLES[name])
        return True

    def _show_view(self, name: str) -> None:
        """Switch the tab's *View* to ``name`` (quietly) and redraw (a view
        taken already with the move's push was drawn by the push's render)."""
        if self._set_view(name):
            self.view.worker.request()

    def back(self) -> None:
        """Give the tab's session the class step again and show the step's view."""
        pos = self.cls.position
        if pos is None:
            self._show(None)
            raise ValueError("no lesson is running: there is no class step to return to")
        lessons.return_to_step(self.view.session, self.view.registry, self.view.settings)
        self._show_view(pos.step.view)

    # ------------------------------------------------------------------ the teacher
    def _authorised(self) -> bool:
        """The GUI push's rule: the teacher token, also on loopback (a loopback tab keeps
        it after one right entry); a wrong one is forgotten."""
        v = self.view
        given = str(v.ui.teacher_token.value)
        v.ui.teacher_token.value = ""
        if not v.settings.teacher_token:
            self._say("⚠️ this server has no teacher token, so the GUI cannot lead a lesson; "
                      "start hyst serve with --teacher-token-file FILE (or set "
                      "HYST_TEACHER_TOKEN) and type that token under Session")
            return False
        if given or not v.teacher:
            ok = v.settings.teacher_ok(given or None)
            v.teacher = ok and not v.settings.public
            if not ok:
                self._say("⚠️ wrong teacher token: type the token hyst serve was given "
                          "under Session, then press the button again")
                return False
        return True

    def _teach(self, action: Any) -> None:
        if not self._authorised():
            return
        result = action()
        if isinstance(result, tuple):
            pos = result[0]
            self._say(md_text(HUB.roster().sent_text(
                f"Step {pos.index + 1} of {len(pos.lesson.steps)} sent")))

    def _start(self) -> tuple[lessons.Position, int, int]:
        lesson = self.choices[str(self.pick.value)]
        return lessons.start(self.view.registry, lesson)

    def _end(self) -> None:
        lessons.end(self.view.registry)
        self._say("lesson ended; every session keeps its model")

    def _say(self, text: str) -> None:
        self.msg.content = text

    def _choose(self, lesson: lessons.Lesson, label: str) -> None:
        self.choices[label] = lesson
        self.pick.options = tuple(self.choices)
        self.pick.value = label

    def _uploaded(self, event: Any) -> None:
        f = event.target.value
        try:
            lesson = lessons.parse_lesson(f.content, self.view.settings)
        except ParameterError as exc:
            self._say(f"⚠️ **Lesson file not loaded:** {md_text(exc)}")
            return
        self._choose(lesson, f"file: {lesson.title[:60]} ({_steps(len(lesson.steps))})")
        self._say(f"loaded {md_text(f.name)}: {_steps(len(lesson.steps))}; start it when the "
                  "class is ready")

    def add_step(self) -> lessons.Lesson:
        """Add the tab's model, input, mismatch and view, with the typed texts, to the
        lesson being made; returns that lesson."""
        if len(self.draft) >= MAX_DRAFT:
            raise ValueError(f"a lesson may have at most {MAX_DRAFT} steps")
        v = self.view
        step = lessons.step_from_config(
            v.session.snapshot()[0], v.figure_name,
            str(self.step_title.value).strip() or f"Step {len(self.draft) + 1}",
            str(self.prompt.value).strip(), str(self.look_for.value).strip(), v.settings)
        self.draft.append(step)
        lesson = self.made()
        for h in (self.step_title, self.prompt, self.look_for):
            h.value = ""
        self._choose(lesson, f"my lesson ({_steps(len(lesson.steps))})")
        self._say(f"added step {len(self.draft)}: {md_text(step.title)}")
        return lesson

    def made(self) -> lessons.Lesson:
        """The lesson made in this tab so far (checked as a lesson file is)."""
        title = str(self.lesson_title.value).strip() or "My lesson"
        return lessons.lesson_from_dict({"title": title, "steps": [
            s.to_dict() for s in self.draft]}, self.view.settings)

    def _download(self, event: Any) -> None:
        if not self.draft:
            self._say("⚠️ add a step first: the lesson has none yet")
            return
        lesson = self.made()
        self.view._send(event, "my-lesson.lesson.json", lesson.to_json().encode())
        self._say(f"sent my-lesson.lesson.json ({_steps(len(lesson.steps))})")

    def close(self) -> None:
        """Stop following the class and the session."""
        self.cls.remove_listener(self._moved)
        if self._session is not None:
            self._session.remove_listener(self._changed)


def _steps(n: int) -> str:
    return f"{n} step" + ("" if n == 1 else "s")
