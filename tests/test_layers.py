"""The layers of docs/architecture.md hold: the import-linter contracts of pyproject.toml.

``.ci/test`` runs ``lint-imports`` too; this test makes a broken contract fail the normal
test suite (``core`` importing ``app``, the services importing a router, the GUI or a
command, a router or the GUI importing ``core`` directly, an import cycle inside ``core``
with function-level imports followed, the jobs' tasks importing the session's actions,
...).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CODE = """
import sys
from importlinter.cli import lint_imports
sys.exit(lint_imports(no_cache=True, no_logo=True))
"""


def test_import_contracts_are_kept() -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-c", CODE], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert "0 broken" in proc.stdout and "7 kept" in proc.stdout, proc.stdout[-2000:]
    assert "no import cycles in core" in proc.stdout
    assert "the tasks never import the session" in proc.stdout  # no actions <-> tasks loop
    assert "no import cycles in app.services" in proc.stdout
