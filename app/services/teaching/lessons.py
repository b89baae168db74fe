"""Lessons: a teacher leads the class through a sequence of steps (no web imports).

A lesson is a small file, JSON or TOML, that is data and never a path::

    {"format": "hyst-lesson/1", "title": "PI basics", "description": "...",
     "steps": [{"title": "A hysteresis loop", "preset": "paper001-example1",
                "view": "loop", "prompt": "...", "look_for": "..."}, ...]}

Each step gives a model (``preset``: a preset's name, or ``model``: a model document of any
registered type), optionally an ``input`` (fields of
:class:`~app.services.explore.config.SignalSpec`, over the model's own default input,
:func:`~app.services.explore.simulation.preset_input`), a ``mismatch``, the ``view`` to show, the
``prompt`` the class reads and what to ``look_for``. :func:`parse_lesson` checks a file
strictly (unknown fields, types, lengths, every step's model built and priced against the
cost limits) and says which step and field is wrong. The lessons shipped with the explorer
(paper 001 and paper 000's examples) are the JSON files of the ``app.lessons`` package.

The class's position (:class:`ClassLesson`, one per session registry, :func:`class_lesson`)
is moved by the teacher (:func:`start`, :func:`go_to`, :func:`end`); every move is the
teacher's push (:func:`app.services.teaching.push.push`: the step's model, input and mismatch to
every recent session, then a ``push`` event carrying the step), and the viser tabs follow
through :meth:`ClassLesson.add_listener`. The position is committed to the session store,
so a restarted server is where the class was. A student who explored returns to the class
step with :func:`return_to_step`.
"""

from __future__ import annotations

import json
import logging
import re
import threading
import weakref
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields, replace
from functools import lru_cache
from importlib import resources
from typing import Any, NotRequired, TypedDict

from app.services.explore.config import CONTROLS, Config, SignalDoc, SignalSpec
from app.services.explore.cost import check_document
from app.services.explore.simulation import VIEWS, preset_doc, preset_input
from app.services.guard.jsonbody import DocumentError, read_document
from app.services.session import actions
from app.services.session.sessions import Session, SessionRegistry
from app.services.settings import Settings
from app.services.storage.store import SessionStore
from app.services.teaching import push as teacher
from app.services.teaching.events import HUB, ClassStepDoc, PushNote
from core.base import model_from_dict
from core.exceptions import ParameterError

__all__ = [
    "FORMAT",
    "MAX_LESSON_BYTES",
    "MAX_STEPS",
    "ClassLesson",
    "Lesson",
    "LessonError",
    "Position",
    "Step",
    "builtin_lesson",
    "builtin_lessons",
    "class_lesson",
    "end",
    "go_to",
    "lesson_from_dict",
    "parse_lesson",
    "return_to_step",
    "start",
    "step_from_config",
]

#: The ``format`` a lesson file may declare (and downloads carry).
FORMAT = "hyst-lesson/1"
#: Largest lesson file, bytes (checked before parsing).
MAX_LESSON_BYTES = 200_000
#: Most steps in one lesson.
MAX_STEPS = 40
#: Longest title (lesson or step), characters.
MAX_TITLE = 120
#: Longest prompt, what-to-look-for or description, characters.
MAX_TEXT = 2000
#: The views a step may show (the *Fit* view needs each student's recording: not a step).
STEP_VIEWS = VIEWS

_LESSON_FIELDS = ("format", "title", "description", "steps")
_STEP_FIELDS = ("title", "preset", "model", "input", "mismatch", "view", "prompt", "look_for")
_SIGNAL_FIELDS = tuple(f.name for f in fields(SignalSpec))
_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")
log = logging.getLogger(__name__)


class LessonError(ParameterError):
    """A lesson file that cannot be used; the message names the step and the field."""


class StepDoc(TypedDict):
    """A step as a lesson file writes it (:meth:`Step.to_dict`): ``preset`` or ``model``."""

    title: str
    preset: NotRequired[str]
    #: the model document (when the step's model came from no preset)
    model: NotRequired[dict[str, Any]]
    input: NotRequired[SignalDoc]
    mismatch: NotRequired[float]
    view: NotRequired[str]
    prompt: NotRequired[str]
    look_for: NotRequired[str]


class LessonDoc(TypedDict):
    """A lesson file's content (:meth:`Lesson.to_dict`)."""

    format: str
    title: str
    description: str
    steps: list[StepDoc]


class LessonSummary(TypedDict):
    """A lesson in a list (:meth:`Lesson.summary`): ``steps`` is their number."""

    name: str | None
    title: str
    description: str
    steps: int


@dataclass(frozen=True)
class Step:
    """One step of a lesson: what the class sees and reads.

    Parameters
    ----------
    title : str
        Short name of the step.
    prompt : str
        What the teacher asks the class (plain text).
    look_for : str
        What to look for in the plot (plain text; may be empty).
    view : str
        The figure on show, one of :data:`STEP_VIEWS`.
    model : dict
        The model document (``to_dict`` form, normalised).
    signal : SignalSpec
        The input signal.
    mismatch : float
        Plant perturbation of the inverse and closed-loop views (-0.9 ... 0.9).
    preset : str or None
        The preset the model came from, when it did.
    """

    title: str
    prompt: str
    look_for: str
    view: str
    model: dict[str, Any]
    signal: SignalSpec
    mismatch: float = 0.0
    preset: str | None = None

    def config(self, base: Config | None = None) -> Config:
        """``base`` (default: a new config) with this step's model, input and mismatch; a
        student's uploaded recording stays in the session but is not used."""
        return replace(base or Config(), model=dict(self.model), signal=self.signal,
                       mismatch=self.mismatch, use_recording=False)

    def to_dict(self) -> StepDoc:
        """The step as it is written in a lesson file (``preset`` or ``model``)."""
        d: StepDoc = {"title": self.title}
        if self.preset is not None:
            d["preset"] = self.preset
        else:
            d["model"] = self.model
        d["input"] = self.signal.to_dict()
        if self.mismatch:
            d["mismatch"] = self.mismatch
        d["view"] = self.view
        d["prompt"] = self.prompt
        if self.look_for:
            d["look_for"] = self.look_for
        return d


@dataclass(frozen=True)
class Lesson:
    """A titled sequence of :class:`Step` (at most :data:`MAX_STEPS`).

    Parameters
    ----------
    title : str
    description : str
    steps : tuple of Step
    name : str or None
        Key of a lesson shipped with the explorer (:func:`builtin_lesson`), else ``None``.
    """

    title: str
    description: str
    steps: tuple[Step, ...]
    name: str | None = None

    def to_dict(self) -> LessonDoc:
        """The lesson file's content (JSON-ready)."""
        return {"format": FORMAT, "title": self.title, "description": self.description,
                "steps": [s.to_dict() for s in self.steps]}

    def to_json(self) -> str:
        """The lesson file (UTF-8 JSON text, indented)."""
        return json.dumps(self.to_dict(), indent=1, ensure_ascii=False) + "\n"

    def summary(self) -> LessonSummary:
        """``{"name", "title", "description", "steps"}`` (the number of steps)."""
        return {"name": self.name, "title": self.title, "description": self.description,
                "steps": len(self.steps)}


# ----------------------------------------------------------------------------- reading
def parse_lesson(content: str | bytes, settings: Settings | None = None, *,
                 name: str | None = None) -> Lesson:
    """The lesson in ``content``: the text of a JSON or TOML lesson file (never a path).

    JSON is recognised by its first character ``{``; anything else is read as TOML.

    Raises
    ------
    LessonError
        If the text is too large, not JSON / TOML, or a field is wrong (the message names
        the step, counted from 1, and the field).
    """
    size = len(content.encode("utf-8") if isinstance(content, str) else content)
    if size > MAX_LESSON_BYTES:
        raise LessonError(f"the lesson file has {size} bytes; a lesson may have at most "
                          f"{MAX_LESSON_BYTES} (about {MAX_STEPS} steps with their texts)")
    if isinstance(content, bytes):
        try:
            content = content.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise LessonError(f"the lesson file is not UTF-8 text (byte {exc.start}); save "
                              "it as UTF-8") from None
    try:
        doc = read_document(content, toml=True, where="lesson", name="the lesson file")
    except DocumentError as exc:
        raise LessonError(str(exc)) from None
    return lesson_from_dict(doc, settings, name=name)


def lesson_from_dict(doc: Any, settings: Settings | None = None, *,
                     name: str | None = None) -> Lesson:
    """Check a parsed lesson document strictly and build its :class:`Lesson`.

    Every step's model is built and priced against ``settings``' limits (default
    :class:`Settings`), so a lesson that starts never fails at a step.

    Raises
    ------
    LessonError
        Naming the step (from 1) and the field that is wrong, and what to write instead.
    """
    settings = settings or Settings()
    if not isinstance(doc, Mapping):
        raise LessonError("a lesson is an object with a title and a list of steps")
    _unknown(doc, _LESSON_FIELDS, "the lesson")
    fmt = doc.get("format", FORMAT)
    if fmt != FORMAT:
        raise LessonError(f"the lesson's format {_quote(fmt)} is not one this explorer "
                          f"reads; write \"format\": \"{FORMAT}\" or leave it out")
    title = _text(doc.get("title"), "the lesson's title", MAX_TITLE, required=True)
    description = _text(doc.get("description", ""), "the lesson's description", MAX_TEXT)
    steps = doc.get("steps")
    if not isinstance(steps, list) or not steps:
        raise LessonError("the lesson needs \"steps\": a list of at least one step")
    if len(steps) > MAX_STEPS:
        raise LessonError(f"the lesson has {len(steps)} steps; a lesson may have at most "
                          f"{MAX_STEPS} (split it into two lessons)")
    return Lesson(title, description,
                  tuple(_step(s, i + 1, settings) for i, s in enumerate(steps)), name)


def _step(d: Any, k: int, settings: Settings) -> Step:
    where = f"step {k}"
    if not isinstance(d, Mapping):
        raise LessonError(f"{where} is not an object with a title, a model and a prompt")
    title = _text(d.get("title"), f"{where}: title", MAX_TITLE, required=True)
    where = f"step {k} ({title})"
    _unknown(d, _STEP_FIELDS, where)
    preset = d.get("preset")
    if (preset is None) == (d.get("model") is None):
        raise LessonError(f"{where}: give either \"preset\" (a preset's name) or \"model\" "
                          "(a model document), exactly one of them")
    if preset is not None:
        if not isinstance(preset, str):
            raise LessonError(f"{where}: preset must be a preset's name (text)")
        try:
            doc = preset_doc(preset)
        except ParameterError as exc:
            raise LessonError(f"{where}: preset {_quote(preset)}: {exc}") from None
        model = doc["model"]
    else:
        if not isinstance(d["model"], Mapping):
            raise LessonError(f"{where}: model must be a model document such as "
                              "{\"type\": \"pi\", \"p0\": 0.72, \"thresholds\": [...], "
                              "\"weights\": [...]}")
        try:
            check_document(d["model"], settings.limits, where="model")
        except ParameterError as exc:
            raise LessonError(f"{where}: {exc}") from None
        try:
            model = model_from_dict(dict(d["model"])).to_dict()
        except (ParameterError, TypeError, KeyError, ValueError) as exc:
            raise LessonError(f"{where}: model: {_plain(exc)}") from None
    signal = _signal(d.get("input"), model, where)
    mismatch = d.get("mismatch", 0.0)
    wrong = CONTROLS["mismatch"].problem(mismatch, "mismatch")
    if wrong:
        raise LessonError(f"{where}: {wrong}")
    view = d.get("view", "loop")
    if view not in STEP_VIEWS:
        raise LessonError(f"{where}: view {_quote(view)} is not a view a step can show; "
                          f"choose one of {', '.join(STEP_VIEWS)}")
    step = Step(title=title, prompt=_text(d.get("prompt"), f"{where}: prompt", MAX_TEXT,
                                          required=True),
                look_for=_text(d.get("look_for", ""), f"{where}: look_for", MAX_TEXT),
                view=view, model=model, signal=signal, mismatch=float(mismatch),
                preset=preset)
    try:  # built and priced now, so the class never meets a step that fails
        actions.checked_config_change(step.config(), None, settings)
    except (ParameterError, TypeError, ValueError) as exc:
        raise LessonError(f"{where}: {_plain(exc)}") from None
    return step


def _signal(d: Any, model: dict[str, Any], where: str) -> SignalSpec:
    base = preset_input(model_from_dict(model))
    if d is None:
        return base
    if not isinstance(d, Mapping):
        raise LessonError(f"{where}: input must be an object with some of "
                          f"{', '.join(_SIGNAL_FIELDS)}")
    _unknown(d, _SIGNAL_FIELDS, f"{where}: input")
    kw: dict[str, Any] = {}
    for key, v in d.items():
        want = getattr(base, key)
        if isinstance(want, str):
            ok = isinstance(v, str)
        elif isinstance(want, int):
            ok = isinstance(v, int) and not isinstance(v, bool)
        else:
            ok = isinstance(v, int | float) and not isinstance(v, bool)
        if not ok:
            kind = "text" if isinstance(want, str) else "a whole number" \
                if isinstance(want, int) else "a number"
            raise LessonError(f"{where}: input.{key} must be {kind}, got {_quote(v)}")
        kw[key] = float(v) if isinstance(want, float) else v
    spec = replace(base, **kw)
    for key, control in CONTROLS.items():  # the sliders a step sets must show it
        if hasattr(spec, key):
            wrong = control.problem(getattr(spec, key), f"input.{key}")
            if wrong:
                raise LessonError(f"{where}: {wrong}")
    return spec


def _unknown(d: Mapping[str, Any], known: tuple[str, ...], where: str) -> None:
    extra = [str(k) for k in d if k not in known]
    if extra:
        raise LessonError(f"{where}: unknown field {_quote(extra[0][:40])}; the fields are "
                          f"{', '.join(known)}")


def _text(v: Any, where: str, limit: int, *, required: bool = False) -> str:
    if v is None and not required:
        return ""
    if not isinstance(v, str):
        raise LessonError(f"{where} must be text" + (" and is missing" if v is None else
                                                     f", got {_quote(v)}"))
    v = v.strip()
    if required and not v:
        raise LessonError(f"{where} is empty; write it")
    if len(v) > limit:
        raise LessonError(f"{where} has {len(v)} characters; at most {limit} fit on a screen")
    if _CONTROL.search(v):
        raise LessonError(f"{where} holds control characters; use plain text")
    return v


def _quote(v: Any) -> str:
    s = json.dumps(v, ensure_ascii=False) if not isinstance(v, str) else repr(v)
    return s if len(s) <= 60 else s[:57] + "..."


def _plain(exc: BaseException) -> str:
    return str(exc).strip("'\"") or type(exc).__name__


# ----------------------------------------------------------------------------- shipped
@lru_cache(maxsize=1)
def _shipped() -> tuple[Lesson, ...]:
    out = []
    for entry in sorted(resources.files("app.lessons").iterdir(), key=lambda p: p.name):
        if entry.name.endswith(".json"):  # "1-pi-basics.json": lesson "pi-basics", first
            name = entry.name.removesuffix(".json").lstrip("0123456789").lstrip("-")
            out.append(parse_lesson(entry.read_bytes(), name=name))
    return tuple(out)


def builtin_lessons() -> list[Lesson]:
    """The lessons shipped with the explorer (the ``app.lessons`` package), in their order."""
    return list(_shipped())


def builtin_lesson(name: str) -> Lesson:
    """The shipped lesson ``name``.

    Raises
    ------
    LessonError
        If there is none (the message lists the names).
    """
    for lesson in _shipped():
        if lesson.name == name:
            return lesson
    raise LessonError(f"no lesson named {_quote(name[:60])}; the lessons are "
                      f"{', '.join(str(x.name) for x in _shipped())}")


def step_from_config(cfg: Config, view: str, title: str, prompt: str, look_for: str = "",
                     settings: Settings | None = None) -> Step:
    """A step made from a session's current state (the teacher's "add as a step"): the
    config's model, input and mismatch, the view on show and the teacher's texts.

    Raises
    ------
    LessonError
        If a text or the view does not fit a lesson (the Fit view needs a recording).
    """
    if view not in STEP_VIEWS:
        raise LessonError(f"the {view} view cannot be a step (it needs each student's own "
                          f"recording); choose one of {', '.join(STEP_VIEWS)}")
    doc = {"title": title or "My step", "model": cfg.model,
           "input": cfg.signal.to_dict(), "mismatch": cfg.mismatch, "view": view,
           "prompt": prompt or "What do you see?", "look_for": look_for}
    preset = actions.matching_preset(cfg.model)
    if preset is not None:
        doc.pop("model")
        doc["preset"] = preset
    return _step(doc, 1, settings or Settings())


# ----------------------------------------------------------------------------- the class
@dataclass(frozen=True)
class Position:
    """Where the class is: ``lesson.steps[index]``.

    Parameters
    ----------
    lesson : Lesson
    index : int
        0-based index of the step (shown as ``index + 1``).
    serial : int
        Increases with every move (a page tells a new move from a repeated event).
    """

    lesson: Lesson
    index: int
    serial: int

    @property
    def step(self) -> Step:
        """The step the class is at."""
        return self.lesson.steps[self.index]

    def to_dict(self) -> ClassStepDoc:
        """What a page shows: the lesson's title, the step (1-based) and its content."""
        s = self.step
        return {"running": True, "title": self.lesson.title, "name": self.lesson.name,
                "step": self.index + 1, "steps": len(self.lesson.steps), "serial": self.serial,
                "step_title": s.title, "prompt": s.prompt, "look_for": s.look_for,
                "view": s.view, "preset": s.preset, "model": s.model,
                "input": s.signal.to_dict(), "mismatch": s.mismatch}


Listener = Callable[["Position | None"], None]


class ClassLesson:
    """The lesson a class follows (none at first); thread-safe.

    Listeners (the viser tabs) are called with the new :class:`Position`, or ``None`` when
    the lesson ends, after every move, from the thread that made it; a move that pushes
    its step (every one but the end) tells them once the sessions have it. With a ``store`` every
    move is committed there and a new ``ClassLesson`` on the same store (a restarted
    server) starts where the class was.

    Parameters
    ----------
    store : SessionStore, optional
        Where the position is kept
        (:meth:`~app.services.storage.store.SessionStore.put_class_state`).
    """

    def __init__(self, store: SessionStore | None = None) -> None:
        #: Held through a whole move (position and push), so moves never interleave.
        self.moves = threading.Lock()
        self._lock = threading.Lock()
        self._position: Position | None = None
        self._serial = 0
        self._listeners: list[Listener] = []
        self._store = store
        saved = None if store is None else store.class_state(_STORE_KEY)
        if saved is not None:
            try:
                doc = json.loads(saved)
                lesson = lesson_from_dict(doc["lesson"], name=doc.get("name"))
                _check_step(lesson, int(doc["index"]) + 1)
                self._position = Position(lesson, int(doc["index"]), 0)
            except (LessonError, ValueError, KeyError, TypeError) as exc:
                log.warning("the stored class lesson was not restored: %s", exc)

    @property
    def position(self) -> Position | None:
        """Where the class is, or ``None`` when no lesson runs."""
        with self._lock:
            return self._position

    def _move(self, lesson: Lesson | None, index: int = 0, *, tell: bool = True
              ) -> Position | None:
        """Set the position; ``tell``: call the listeners now (a move that pushes its step
        tells them after the push, :meth:`_tell`)."""
        with self._lock:
            self._serial += 1
            self._position = None if lesson is None else Position(lesson, index, self._serial)
            pos = self._position
            if self._store is not None:  # a restarted server starts where the class was
                self._store.put_class_state(_STORE_KEY, None if lesson is None else json.dumps(
                    {"lesson": lesson.to_dict(), "name": lesson.name, "index": index}))
        if tell:
            self._tell(pos)
        return pos

    def _tell(self, pos: Position | None) -> None:
        with self._lock:
            listeners = list(self._listeners)
        for fn in listeners:
            try:
                fn(pos)
            except Exception:  # noqa: BLE001 - a closed tab must not stop the class
                pass

    def _move_and_push(self, lesson: Lesson, index: int,
                       push: Callable[[Position], tuple[int, int]]
                       ) -> tuple[Position, int, int]:
        """Move to ``lesson``'s step ``index`` and ``push`` it, then tell the listeners:
        a tab told first would compare its session, still on the old step, with the new
        one and say "You are exploring" until the push reached it (seen with ten viser
        tabs in ``benchmarks/bench_class.py``)."""
        pos = self._move(lesson, index, tell=False)
        assert pos is not None
        try:
            return (pos, *push(pos))
        finally:
            self._tell(pos)

    def add_listener(self, fn: Listener) -> None:
        """Call ``fn(position)`` after every move."""
        with self._lock:
            self._listeners.append(fn)

    def remove_listener(self, fn: Listener) -> None:
        """Stop calling ``fn`` (no error if it is not listening)."""
        with self._lock:
            if fn in self._listeners:
                self._listeners.remove(fn)


#: The key of the class's lesson in the session store.
_STORE_KEY = "lesson"
_CLASSES: weakref.WeakKeyDictionary[SessionRegistry, ClassLesson] = \
    weakref.WeakKeyDictionary()
_CLASSES_LOCK = threading.Lock()


def class_lesson(registry: SessionRegistry) -> ClassLesson:
    """The class lesson of the explorer that holds ``registry`` (REST and viser share it)."""
    with _CLASSES_LOCK:
        cl = _CLASSES.get(registry)
        if cl is None:
            cl = _CLASSES[registry] = ClassLesson(registry.store)
        return cl


def _push(registry: SessionRegistry, pos: Position) -> tuple[int, int]:
    s = pos.step
    return teacher.push(registry, model=s.model, signal=s.signal, mismatch=s.mismatch,
                        note={"preset": s.preset, "title": s.title, "signal": True,
                              "lesson": pos.to_dict()})


def start(registry: SessionRegistry, lesson: Lesson, step: int = 1
          ) -> tuple[Position, int, int]:
    """Start ``lesson`` at ``step`` (from 1) for the class: the teacher's push of that step.
    Returns ``(position, sessions changed, pages told)``.

    Raises
    ------
    LessonError
        If ``step`` is not a step of the lesson.
    """
    _check_step(lesson, step)
    cl = class_lesson(registry)
    with cl.moves:
        return cl._move_and_push(lesson, step - 1, lambda p: _push(registry, p))


def go_to(registry: SessionRegistry, step: int | None = None, move: int = 0
          ) -> tuple[Position, int, int]:
    """Move the class to ``step`` (from 1), or ``move`` steps on (-1: back); the teacher's
    push of that step.

    Raises
    ------
    LessonError
        If no lesson runs, or the step is before the first or after the last.
    """
    cl = class_lesson(registry)
    with cl.moves:  # two quick clicks on Next: steps k+1 and k+2, pushed in that order
        pos = cl.position
        if pos is None:
            raise LessonError("no lesson is running: start one first")
        target = pos.index + 1 + move if step is None else step
        _check_step(pos.lesson, target)
        return cl._move_and_push(pos.lesson, target - 1, lambda p: _push(registry, p))


def end(registry: SessionRegistry) -> int:
    """End the class's lesson (the sessions keep their models); tells every open page.
    Returns how many pages were told."""
    cl = class_lesson(registry)
    with cl.moves:
        cl._move(None)
        return HUB.broadcast({"kind": "lesson", "lesson": None})


def push_to_class(registry: SessionRegistry, *, model: dict[str, Any] | None = None,
                  signal: SignalSpec | None = None, note: PushNote | None = None
                  ) -> tuple[int, int]:
    """The teacher's push (:func:`app.services.teaching.push.push`); while a lesson runs, the
    pushed model and/or input become the class step's (the step's preset dropped), so
    the students who follow stay on the class step, and *Back to the class step* gives
    the pushed model. The event then carries the changed step (``lesson``, with
    ``edit: true``). Returns ``(sessions changed, pages told)``.

    Raises
    ------
    ParameterError
        If there is nothing to push.
    """
    cl = class_lesson(registry)
    with cl.moves:
        pos = cl.position
        if pos is None or (model is None and signal is None):
            return teacher.push(registry, model=model, signal=signal, note=note)
        s = pos.step
        step = replace(s, model=dict(s.model if model is None else model),
                       signal=s.signal if signal is None else signal,
                       preset=s.preset if model is None else None)
        steps = tuple(step if i == pos.index else x for i, x in enumerate(pos.lesson.steps))
        return cl._move_and_push(replace(pos.lesson, steps=steps), pos.index, lambda new: (
            teacher.push(registry, model=model, signal=signal, note={
                **(note or {}), "lesson": new.to_dict(), "edit": True})))[1:]


def _check_step(lesson: Lesson, step: int) -> None:
    n = len(lesson.steps)
    if not 1 <= step <= n:
        where = "the first step" if step < 1 else "the last step"
        raise LessonError(f"there is no step {step}: the lesson has steps 1 to {n} "
                          f"(already at {where}?)")


def return_to_step(session: Session, registry: SessionRegistry, settings: Settings) -> int:
    """Give ``session`` the class's current step again (a student who explored comes back);
    returns the session's new version.

    Raises
    ------
    LessonError
        If no lesson is running.
    """
    pos = class_lesson(registry).position
    if pos is None:
        raise LessonError("no lesson is running: there is no class step to return to")
    step = pos.step
    return actions.change_config(session, step.config, settings)
