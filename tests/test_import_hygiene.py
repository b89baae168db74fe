"""``core`` stays free of web and plotting libraries (they cost start-up time and weight).

In a fresh interpreter, ``import core`` and then every ``core`` submodule; none of viser,
fastapi, plotly or uvicorn may end up in ``sys.modules``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BANNED = ("viser", "fastapi", "plotly", "uvicorn", "starlette")

CODE = """
import importlib, json, pkgutil, sys
import core
after_core = sorted(m for m in sys.modules if m.split('.')[0] in BANNED)
names = [m.name for m in pkgutil.walk_packages(core.__path__, 'core.')]
failed = {}
for name in names:
    try:
        importlib.import_module(name)
    except Exception as exc:  # reported, so a broken module is visible, not hidden
        failed[name] = repr(exc)
after_all = sorted(m for m in sys.modules if m.split('.')[0] in BANNED)
print(json.dumps({"after_core": after_core, "after_all": after_all, "names": names,
                  "failed": failed}))
"""


def _run() -> dict:
    code = f"BANNED = {BANNED!r}\n" + CODE
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_core_imports_no_web_or_plotting_libraries() -> None:
    res = _run()
    assert res["after_core"] == [], f"import core pulled in {res['after_core']}"
    assert res["after_all"] == [], f"core submodules pulled in {res['after_all']}"
    assert "core.pi" in res["names"] and "core.kernels" in res["names"]
    assert res["failed"] == {}, f"core submodules failed to import: {res['failed']}"
