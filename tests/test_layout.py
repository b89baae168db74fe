"""Tests mirror the package layout, so a test is found where its module is (issue 17).

``tests/<pkg>/<sub>/test_<name>.py`` needs a package folder ``<pkg>/<sub>/`` (``core/fitting/``),
and ``<name>`` must start with one of its modules or subpackages (``test_pi_streaming.py`` for
``pi.py``) or with the package's own name (``test_diagnosis_holds.py`` tests ``core.diagnosis``
as a whole). Top-level ``tests/test_<name>.py`` files name a top-level folder (``examples``,
``benchmarks``, ``docs``). Journeys across packages, benchmark checks and the browser tests are
listed in :data:`ALLOWED` with the reason.
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TESTS = ROOT / "tests"

#: Test modules that cross the package layout on purpose.
ALLOWED = {
    "tests/e2e": "real-browser journeys over the whole app",
    "tests/test_compensation_loop.py": "journey: diagnose -> invert -> track, CLI and C",
    "tests/test_benchmark_families.py": "checks benchmarks/diagnosis/families.py's plants",
    "tests/test_benchmark_sealed.py": "checks the sealed set's builders (benchmarks/diagnosis)",
    "tests/test_benchmark_bipolar.py": "checks the bipolar development class "
                                       "(benchmarks/diagnosis/bipolar.py)",
    "tests/test_benchmark_ceiling.py": "checks the told-the-name ceiling "
                                       "(benchmarks/diagnosis/ceiling.py)",
    "tests/test_benchmark_triangle.py": "checks the growing-triangle development class "
                                        "(benchmarks/diagnosis/triangle.py)",
    "tests/test_benchmark_opensees_dev.py": "checks the OpenSees development class "
                                            "(benchmarks/diagnosis/opensees_plants.py)",
    "tests/test_import_hygiene.py": "a rule over every core module",
    "tests/test_layout.py": "this rule",
    "tests/test_layers.py": "the import-linter contracts over core and app",
    "tests/app/test_fit_kinds.py": "the registry's fit kinds in the CLI, batch, API and GUI",
}


def _allowed(rel: str) -> bool:
    return any(rel == a or rel.startswith(a + "/") for a in ALLOWED)


def _mirror_problem(path: Path) -> str | None:
    rel = path.relative_to(TESTS)
    name = path.stem.removeprefix("test_")
    if len(rel.parts) == 1:
        folders = {p.name for p in ROOT.iterdir() if p.is_dir() and not p.name.startswith(".")}
        return None if name in folders else "names no top-level folder"
    package = ROOT.joinpath(*rel.parts[:-1])
    if not (package / "__init__.py").is_file():
        return f"{package.relative_to(ROOT)}/ is not a package"
    names = {p.stem for p in package.glob("*.py") if p.stem != "__init__"}
    names |= {p.name for p in package.iterdir() if (p / "__init__.py").is_file()}
    names.add(package.name)
    if any(name == n or name.startswith(n + "_") for n in names):
        return None
    return f"test_{name} starts with no module of {package.relative_to(ROOT)}/"


def test_every_test_module_mirrors_a_package_module() -> None:
    modules = sorted(TESTS.rglob("test_*.py"))
    assert len(modules) > 60
    bad = []
    for path in modules:
        rel = path.relative_to(ROOT).as_posix()
        if _allowed(rel):
            continue
        problem = _mirror_problem(path)
        if problem:
            bad.append(f"{rel}: {problem}")
    assert bad == [], "move or rename (or allow with a reason):\n" + "\n".join(bad)


def test_every_test_folder_is_a_package() -> None:
    """``from tests.core.model_zoo import ...`` and unique module names need ``__init__.py``."""
    missing = [d.relative_to(ROOT).as_posix() for d in TESTS.rglob("*")
               if d.is_dir() and d.name != "__pycache__" and any(d.glob("test_*.py"))
               and not (d / "__init__.py").is_file()]
    assert missing == []


def test_the_allow_list_has_no_stale_entries() -> None:
    assert [a for a in ALLOWED if not (ROOT / a).exists()] == []
