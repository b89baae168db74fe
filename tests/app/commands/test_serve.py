"""``hyst serve`` end to end in a subprocess: it starts, prints its URLs and answers."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from app.cli import build_parser

ROOT = Path(__file__).resolve().parents[3]


def test_serve_arguments() -> None:
    args = build_parser().parse_args(["serve", "--host", "0.0.0.0", "--port", "9000",
                                      "--viser-port", "9001", "--no-browser"])
    assert (args.host, args.port, args.viser_port, args.no_browser) == ("0.0.0.0", 9000, 9001,
                                                                          True)
    defaults = build_parser().parse_args(["serve"])
    assert defaults.host is None and callable(defaults.func)  # Settings: 127.0.0.1


def test_settings_from_env(monkeypatch) -> None:  # noqa: ANN001
    from app.services.settings import Settings

    monkeypatch.setenv("HYST_VISER_PORT", "9123")
    monkeypatch.setenv("HYST_MAX_OPERATORS", "12")
    s = Settings.from_env(port=None, host="0.0.0.0")
    assert (s.host, s.port, s.viser_port, s.max_operators) == ("0.0.0.0", 8000, 9123, 12)
    assert Settings().host == "127.0.0.1"


def test_serve_starts_prints_urls_and_serves(tmp_path: Path) -> None:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "app", "serve", "--no-browser", "--port", "0", "--viser-port",
         "0", "--state-dir", str(tmp_path)], cwd=ROOT, env=env, stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True)
    try:
        web = gui = None
        deadline = time.monotonic() + 60
        assert proc.stdout is not None
        while time.monotonic() < deadline and (web is None or gui is None):
            line = proc.stdout.readline()
            if not line:
                break
            if "web page:" in line:
                web = line.split("web page:")[1].split()[0]
            if "GUI (viser):" in line:
                gui = line.split("GUI (viser):")[1].split()[0]
        assert web and gui, "serve did not announce its URLs"
        with urllib.request.urlopen(web + "api/health", timeout=10) as r:
            assert json.load(r) == {"status": "ok"}
        with urllib.request.urlopen(gui, timeout=10) as r:
            assert r.status == 200 and b"<html" in r.read(2000).lower()
    finally:
        proc.terminate()
        proc.wait(timeout=20)
