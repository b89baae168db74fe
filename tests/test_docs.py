"""The docs site and the README stay true: the site builds strictly, the Python blocks run, and
every dotted ``core.``/``app.`` name and every ``tests/...py`` path they mention exists.

Convention for code blocks in ``README.md`` and ``docs/pages/**/*.md``: a fenced ``python``
block is run (each in its own interpreter, cwd a temporary folder, ``HYST_QUICK=1``); a block
preceded by the line ``<!-- illustrative -->`` is not (it uses files or names the reader has).
Shell, ``json``, ``text`` and other blocks are never run.
"""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = ROOT / "docs" / "pages"
DOCS = [ROOT / "README.md", *sorted(PAGES.rglob("*.md"))]
SKIP_MARK = "<!-- illustrative -->"

FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```", re.M | re.S)
# A dotted name of the package (core.pi.PIModel), not a file name (docs/core.md, static/app.js).
DOTTED = re.compile(r"(?<![\w/.-])((?:core|app)(?:\.[A-Za-z_]\w*)+)")
TEST_PATH = re.compile(r"(?<![\w/.-])(tests/[\w/]+\.py)")
FILE_SUFFIXES = ("md", "js", "py", "json", "csv", "html", "yml")


def _env() -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT), HYST_QUICK="1", OPENBLAS_NUM_THREADS="1",
               NO_MKDOCS_2_WARNING="1")
    env.pop("PYTHONSTARTUP", None)
    return env


def _python_blocks() -> list[tuple[str, str]]:
    """(id, code) of every runnable python block of the README and the pages."""
    out = []
    for path in DOCS:
        text = path.read_text(encoding="utf-8")
        for m in FENCE.finditer(text):
            if m.group(1) != "python":
                continue
            before = text[:m.start()].rstrip().rsplit("\n", 1)[-1].strip()
            if before == SKIP_MARK:
                continue
            line = text.count("\n", 0, m.start()) + 1
            out.append((f"{path.relative_to(ROOT)}:{line}", m.group(2)))
    return out


def test_site_builds_strictly(tmp_path: Path) -> None:
    """Broken links, pages missing from the nav and API names mkdocstrings cannot find fail."""
    site = tmp_path / "site"
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q",
                        "-f", str(ROOT / "docs" / "mkdocs.yml"), "-d", str(site)],
                       capture_output=True, text=True, env=_env(), cwd=tmp_path, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    for page in ("explore", "fit", "diagnose", "compensate", "export", "batch", "serve",
                 "architecture", "benchmarks", "papers"):
        assert (site / f"{page}.html").is_file(), page
    api = (site / "api" / "fitting.html").read_text(encoding="utf-8")
    assert "PIRegressor" in api and "n_operators" in api  # rendered from the docstrings
    # Like the server's pages (tests/app/test_server_offline_docs.py): nothing from a CDN.
    for html in site.rglob("*.html"):
        remote = re.findall(r'<(?:script|link)[^>]+(?:src|href)="https?://[^"]+"',
                            html.read_text(encoding="utf-8"))
        assert remote == [], f"{html.name} loads {remote}"


BLOCKS = _python_blocks()


def test_there_are_runnable_blocks() -> None:
    assert len(BLOCKS) >= 3


@pytest.mark.parametrize("code", [c for _, c in BLOCKS], ids=[i for i, _ in BLOCKS])
def test_python_block_runs(code: str, tmp_path: Path) -> None:
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=_env(), cwd=tmp_path, timeout=60)
    assert r.returncode == 0, r.stderr[-3000:]


def _resolves(name: str) -> bool:
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ModuleNotFoundError:
            continue
        try:
            for attr in parts[k:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return False
        return True
    return False


def _mentions(pattern: re.Pattern[str]) -> list[tuple[str, str]]:
    found = []
    for path in DOCS:
        for m in pattern.finditer(path.read_text(encoding="utf-8")):
            name = m.group(1)
            if name.rsplit(".", 1)[-1] in FILE_SUFFIXES and pattern is DOTTED:
                continue  # a file name such as core.md
            found.append((str(path.relative_to(ROOT)), name))
    return sorted(set(found))


def test_every_dotted_name_in_the_docs_imports() -> None:
    names = _mentions(DOTTED)
    assert len(names) > 20
    stale = [f"{page}: {name}" for page, name in names if not _resolves(name)]
    assert stale == [], "names in the docs that do not import:\n" + "\n".join(stale)


def test_every_test_file_named_in_the_docs_exists() -> None:
    missing = [f"{page}: {p}" for page, p in _mentions(TEST_PATH) if not (ROOT / p).is_file()]
    assert missing == [], "\n".join(missing)
