"""A teacher push survives a page reload and a killed server (``hyst serve --state-dir``).

The explorer runs as its own process (``python -m app serve``) so it can be killed with
SIGKILL mid-class and started again on the same port and state directory.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from .conftest import TEACHER_TOKEN
from .test_web_journeys import _clean, _listening, _open, _text_has

ROOT = Path(__file__).resolve().parents[2]
PUSHED = "() => document.getElementById('model-json').value.includes('digitized')"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Explorer:
    """``python -m app serve`` on ``port`` with its sessions in ``state``."""

    def __init__(self, state: Path, token_file: Path) -> None:
        self.port = _free_port()
        self.url = f"http://127.0.0.1:{self.port}/"
        self.args = [sys.executable, "-m", "app", "serve", "--port", str(self.port),
                     "--no-viser", "--no-browser", "--state-dir", str(state),
                     "--teacher-token-file", str(token_file)]
        self.proc: subprocess.Popen[bytes] | None = None

    def start(self) -> None:
        env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
        self.proc = subprocess.Popen(self.args, cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 60
        while True:
            try:
                urllib.request.urlopen(self.url + "api/capabilities", timeout=2).close()
                return
            except OSError:
                if time.monotonic() > deadline or self.proc.poll() is not None:
                    raise RuntimeError("the explorer did not start") from None
                time.sleep(0.2)

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()  # SIGKILL: no shutdown code runs
            self.proc.wait(10)


@pytest.fixture
def explorer(tmp_path: Path, browser: Any) -> Iterator[Explorer]:
    del browser  # skips without chromium before a server is started
    token = tmp_path / "token"
    token.write_text(TEACHER_TOKEN)
    ex = Explorer(tmp_path / "state", token)
    ex.start()
    yield ex
    ex.kill()


def test_push_survives_reload_and_kill(browser: Any, explorer: Explorer, shot: Any) -> None:
    ctx_s, student, log_s = _open(browser, explorer.url)
    ctx_t, teacher, log_t = _open(browser, explorer.url)
    code = student.inner_text("#code")
    _listening(explorer.url, student)  # the student's event stream is open
    teacher.click("#teacher summary")
    teacher.fill("#teacher-token", TEACHER_TOKEN)
    teacher.select_option("#teacher-preset", "paper000-three-operators")
    teacher.click("#teacher-push")
    _text_has(teacher, "teacher-msg", "Pushed")
    student.wait_for_function(PUSHED)
    # a reload reads the session back: the pushed model, not the old one
    student.reload()
    student.wait_for_selector("body[data-ready]")
    assert student.inner_text("#code") == code
    student.wait_for_function(PUSHED)
    # the server is killed mid-class and started again: the code brings the push back
    explorer.kill()
    explorer.start()
    student.reload()
    student.wait_for_selector("body[data-ready]")
    student.wait_for_selector("#figure .main-svg")
    assert student.inner_text("#code") == code
    student.wait_for_function(PUSHED)
    assert student.is_hidden("#live-note")  # no "your session is gone" note
    assert student.input_value("#offset") == "5"
    shot(student, "web-push-after-restart")
    # while the server was down the pages' event streams failed to reconnect; nothing else
    for page, log in ((student, log_s), (teacher, log_t)):
        log["errors"] = [e for e in log["errors"] if "Failed to load resource: net::ERR_" not in e]
        _clean(page, log)
    ctx_s.close()
    ctx_t.close()
