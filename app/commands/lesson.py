"""``hyst lesson``: the shipped lessons, and checking a lesson file before class.

``hyst lesson --list`` lists the lessons shipped with the explorer, ``hyst lesson NAME -o
FILE`` writes one as a lesson file (to read, change and load in the explorer), and ``hyst
lesson --check FILE`` reads a lesson file (JSON or TOML) as the explorer does and prints
its steps, or says which step and field is wrong (exit code 2).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from app.services.runs.inputs import CommandError, existing_file
from app.services.teaching import lessons

from ._common import add_json_flag, emit

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    """Add the ``lesson`` sub-command."""
    p = subparsers.add_parser(
        "lesson",
        help="list the shipped lessons, write one as a lesson file, or check a lesson file",
        description="Lessons a teacher leads in the explorer (hyst serve): a sequence of "
                    "steps, each with a model, an input, a view, a prompt and what to look "
                    "for. Start one from the Teacher panel of the web page or the Lesson "
                    "folder of the viser GUI.",
    )
    p.add_argument("name", nargs="?", metavar="NAME", help="a shipped lesson (see --list)")
    p.add_argument("--list", action="store_true", help="list the shipped lessons and exit")
    p.add_argument("-o", "--output", metavar="FILE.json", help="where to write lesson NAME")
    p.add_argument("--check", metavar="FILE", help="read a lesson file (JSON or TOML) as the "
                                                   "explorer does and print its steps")
    add_json_flag(p)
    p.set_defaults(func=run)


def _steps(lesson: lessons.Lesson) -> str:
    return "\n".join(f"  {i}. {s.title} [{s.view}]: {s.prompt[:70]}"
                     + ("..." if len(s.prompt) > 70 else "")
                     for i, s in enumerate(lesson.steps, 1))


def run(args: argparse.Namespace) -> int:
    """List, write or check lessons."""
    if args.list:
        items = [x.summary() for x in lessons.builtin_lessons()]
        width = max(len(x["name"]) for x in items)
        emit(args, "\n".join(f"{x['name']:<{width}}  {x['title']} ({x['steps']} steps)"
                             for x in items), {"lessons": items})
        return 0
    if args.check:
        path = existing_file(args.check, "lesson file")
        size = path.stat().st_size
        if size > lessons.MAX_LESSON_BYTES:
            raise CommandError(f"{path} has {size} bytes; a lesson file may have at most "
                               f"{lessons.MAX_LESSON_BYTES}")
        try:
            lesson = lessons.parse_lesson(path.read_bytes())
        except lessons.LessonError as exc:
            raise CommandError(f"{path}: {exc}") from None
        emit(args, f"{path}: {lesson.title}, {len(lesson.steps)} steps, all usable\n"
                   + _steps(lesson), {"file": str(path), **lesson.to_dict()})
        return 0
    if not args.name:
        raise CommandError("give a lesson NAME (and --output FILE.json), --list or --check "
                           "FILE")
    try:
        lesson = lessons.builtin_lesson(args.name)
    except lessons.LessonError as exc:
        raise CommandError(str(exc)) from None
    if not args.output:
        raise CommandError(f"give --output FILE.json to write lesson {args.name!r}")
    out = Path(args.output)
    out.write_text(lesson.to_json(), encoding="utf-8")
    emit(args, f"wrote {out}: {lesson.title} ({len(lesson.steps)} steps)\n" + _steps(lesson),
         {"output": str(out), "name": lesson.name, "steps": len(lesson.steps)})
    return 0
