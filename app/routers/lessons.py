"""Lessons: the shipped lessons, checking a lesson file, and the class's lesson.

``GET /api/lessons`` lists the lessons shipped with the explorer, ``GET /api/lessons/{name}``
gives one as a lesson file, ``POST /api/lessons/check`` reads a lesson file (JSON or TOML
text as the body, never a path) and answers its checked content or a 422 naming the step
and the field. ``GET /api/lesson`` says where the class is (any page may ask).

The teacher moves the class (``POST /api/teacher/lesson`` starts a lesson, ``POST
/api/teacher/lesson/step`` goes to a step, ``DELETE /api/teacher/lesson`` ends it) under
the rule of ``POST /api/teacher/push`` (:func:`~app.routers.deps.require_teacher`); each move
is that push (the step's model, input and mismatch to every recent session, and a ``push``
event carrying the step, see :mod:`app.services.teaching.lessons`). A student who explored comes
back with ``POST /api/sessions/{code}/lesson/return``.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Header, HTTPException, Request
from pydantic import BaseModel, Field

from app.services.teaching import lessons
from app.services.teaching.events import HUB

from .deps import RegistryDep, SessionDep, SettingsDep, read_body, require_teacher
from .schemas import SessionOut, session_json

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["lessons"])


class LessonSummaryOut(BaseModel):
    """A lesson shipped with the explorer."""

    name: str = Field(description="its name, for GET /api/lessons/{name} and starting it")
    title: str
    description: str
    steps: int = Field(description="how many steps it has")


class LessonOut(BaseModel):
    """A lesson file's content (``format``, ``title``, ``description``, ``steps``)."""

    format: str = Field(description=f"always {lessons.FORMAT!r}")
    title: str
    description: str
    steps: list[dict[str, Any]] = Field(description="the steps, as a lesson file has them")


class ClassLessonOut(BaseModel):
    """Where the class is; only ``running`` when no lesson runs."""

    running: bool
    title: str | None = None
    name: str | None = Field(None, description="the shipped lesson's name, if it is one")
    step: int | None = Field(None, description="the class's step, from 1")
    steps: int | None = Field(None, description="how many steps the lesson has")
    serial: int | None = Field(None, description="increases with every move of the class")
    step_title: str | None = None
    prompt: str | None = None
    look_for: str | None = None
    view: str | None = Field(None, description="the view to show")
    preset: str | None = None
    model: dict[str, Any] | None = None
    input: dict[str, Any] | None = None
    mismatch: float | None = None
    sessions: int | None = Field(None, description="sessions given the step (a move)")
    pages: int | None = Field(None, description="open pages told (a move)")
    text: str | None = Field(None, description="what the teacher reads after a move: the "
                                               "step and the class connected now")


class LessonStartIn(BaseModel):
    """A lesson for the class: a shipped one by name, or a lesson file's content."""

    name: str | None = Field(None, max_length=100, description="a shipped lesson's name")
    lesson: dict[str, Any] | None = Field(None, description="a lesson file's content")
    step: int = Field(1, ge=1, le=lessons.MAX_STEPS, description="the step to start at")


class LessonStepIn(BaseModel):
    """Where the class goes: a step number, or a move (1: next, -1: previous)."""

    step: int | None = Field(None, ge=1, le=lessons.MAX_STEPS, description="from 1")
    move: int = Field(0, ge=-1, le=1, description="1: the next step, -1: the previous one")


@router.get("/lessons", response_model=list[LessonSummaryOut])
def list_lessons() -> list[dict[str, Any]]:
    """The lessons shipped with the explorer (paper 001 and paper 000's examples)."""
    return [x.summary() for x in lessons.builtin_lessons()]


@router.get("/lessons/{name}", response_model=LessonOut)
def get_lesson(name: str) -> dict[str, Any]:
    """A shipped lesson as a lesson file (save it, change it, load it again)."""
    try:
        return lessons.builtin_lesson(name).to_dict()
    except lessons.LessonError as exc:
        raise HTTPException(404, str(exc)) from None


@router.post("/lessons/check", response_model=LessonOut, openapi_extra={"requestBody": {
    "required": True, "content": {"application/json": {}, "application/toml": {},
                                  "text/plain": {}}}})
async def check_lesson(request: Request, settings: SettingsDep) -> dict[str, Any]:
    """Read a lesson file (its JSON or TOML text is the body) and answer its checked
    content, or 422 naming the step (from 1) and the field that is wrong."""
    body = await read_body(request, lessons.MAX_LESSON_BYTES)
    return lessons.parse_lesson(body, settings).to_dict()


@router.get("/lesson", response_model=ClassLessonOut, response_model_exclude_none=True)
def class_lesson(registry: RegistryDep) -> dict[str, Any]:
    """Where the class is in its lesson (``running: false`` when none runs)."""
    pos = lessons.class_lesson(registry).position
    return {"running": False} if pos is None else pos.to_dict()


def _moved(pos: lessons.Position, sessions: int, pages: int) -> dict[str, Any]:
    what = f"Step {pos.index + 1} of {len(pos.lesson.steps)} sent"
    return {**pos.to_dict(), "sessions": sessions, "pages": pages,
            "text": HUB.roster().sent_text(what)}


@router.post("/teacher/lesson", response_model=ClassLessonOut,
             response_model_exclude_none=True)
def start_lesson(
    body: LessonStartIn,
    registry: RegistryDep,
    settings: SettingsDep,
    x_teacher_token: str | None = Header(default=None),
) -> dict[str, Any]:
    """Teacher: start a lesson for the class at ``step`` (pushed to every session)."""
    require_teacher(settings, x_teacher_token)
    if (body.name is None) == (body.lesson is None):
        raise HTTPException(422, "give either the name of a shipped lesson or a lesson")
    if body.name is not None:
        try:
            lesson = lessons.builtin_lesson(body.name)
        except lessons.LessonError as exc:
            raise HTTPException(404, str(exc)) from None
    else:
        lesson = lessons.lesson_from_dict(body.lesson, settings)
    return _moved(*lessons.start(registry, lesson, body.step))


@router.post("/teacher/lesson/step", response_model=ClassLessonOut,
             response_model_exclude_none=True)
def lesson_step(
    body: LessonStepIn,
    registry: RegistryDep,
    settings: SettingsDep,
    x_teacher_token: str | None = Header(default=None),
) -> dict[str, Any]:
    """Teacher: move the class to ``step``, or one step on or back (pushed)."""
    require_teacher(settings, x_teacher_token)
    if lessons.class_lesson(registry).position is None:
        raise HTTPException(409, "no lesson is running: start one first")
    if body.step is None and body.move == 0:
        raise HTTPException(422, "give the step to go to, or move: 1 (next) or -1 (previous)")
    return _moved(*lessons.go_to(registry, body.step, body.move))


@router.delete("/teacher/lesson", response_model=ClassLessonOut,
               response_model_exclude_none=True)
def end_lesson(
    registry: RegistryDep,
    settings: SettingsDep,
    x_teacher_token: str | None = Header(default=None),
) -> dict[str, Any]:
    """Teacher: end the lesson (every session keeps the model it has)."""
    require_teacher(settings, x_teacher_token)
    pages = lessons.end(registry)
    return {"running": False, "pages": pages,
            "text": f"Lesson ended; every page keeps its model "
                    f"({HUB.roster().open_text})."}


@router.post("/sessions/{code}/lesson/return", response_model=SessionOut,
             response_model_exclude_unset=True)
def return_to_class(session: SessionDep, registry: RegistryDep,
                    settings: SettingsDep) -> dict[str, Any]:
    """Give this session the class's current step again (after exploring); 409 when no
    lesson runs."""
    try:
        lessons.return_to_step(session, registry, settings)
    except lessons.LessonError as exc:
        raise HTTPException(409, str(exc)) from None
    return session_json(session)
