"""Refresh ``docs/pages/screenshots/`` from the browser tests.

Run: ``.venv/bin/python -m tests.e2e.refresh_screenshots`` (from the repository root).

The browser tests always write their screenshots to a temporary folder, so a test run
never changes tracked files; this command runs the tests that take the documented
screenshots with ``HYST_SCREENSHOTS`` pointing at ``docs/pages/screenshots/``. Look at the
PNGs before committing them.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: The tests whose screenshots docs/pages/serve.md, explore.md and lessons.md show.
TESTS = [
    "tests/e2e/test_static_page.py::test_page_loads_slider_updates_plot",
    "tests/e2e/test_static_page.py::test_csv_upload_fit_diagnosis_download",
    "tests/e2e/test_web_journeys.py::test_phone_viewport_plot_usable",
    "tests/e2e/test_web_journeys.py::test_teacher_push_reaches_two_students_live",
    "tests/e2e/test_web_journeys.py::test_deadzone_operators_stack_to_y",
    "tests/e2e/test_jobs_page.py::test_diagnosis_progress_and_cancel",
    "tests/e2e/test_viser_gui.py",
    "tests/e2e/test_viser_layout.py::test_phone_shows_a_plot",
    "tests/e2e/test_viser_layout.py::test_laptop_panel_leaves_the_cube_in_view",
    "tests/e2e/test_lesson_journey.py",
]


def main() -> int:
    """Run :data:`TESTS` with screenshots going to ``docs/pages/screenshots/``."""
    out = ROOT / "docs" / "pages" / "screenshots"
    out.mkdir(parents=True, exist_ok=True)
    os.environ["HYST_SCREENSHOTS"] = str(out)
    os.chdir(ROOT)
    code = pytest.main(["-q", "-p", "no:cacheprovider", *TESTS])
    print(f"screenshots in {out}: " + ", ".join(sorted(p.name for p in out.glob("*.png"))))
    return int(code)


if __name__ == "__main__":
    sys.exit(main())
