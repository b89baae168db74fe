"""Every registered model type exports to C99 and matches Python on 100,000 samples.

All generated blocks are compiled into ONE program (one gcc call) with a driver that runs
model ``argv[1]`` on stdin; each run writes, per sample, ``inv(u)``, ``fwd(inv(u))`` and
``fwd(u)``. References: the Python models (the causal form of compensators with a preview),
and forward(inverse(u)) = u (exact types) or the stated bound.
"""

from __future__ import annotations

import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

from core.base import Chain, Model
from core.export_c import CExportError, generate_c
from core.models import model_types
from core.pi import PIModel
from core.stages import Delay, causal_form
from tests.core.model_zoo import DIAGNOSED, DT, EX1, ZOO, turning_points

GCC = shutil.which("gcc")
CFLAGS = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2"]
N = 100_000

#: Types whose compensator is exact: forward(inverse(u)) == u to 1e-9 of the range. (Not
#: ``tanh-envelope-inverse`` as a *forward* model: where the envelope switches branch its
#: output can move against its input, so the inverse of the inverse switches late.)
EXACT = {
    "pi", "chain", "offset", "lag", "lag-inverse", "creep", "creep-inverse", "drift",
    "asymmetry", "asymmetry-inverse", "rate", "rate-inverse", "initial-memory", "deadzone",
    "gpi-deadzone", "mpi", "tanh-envelope", "gpi-tanh", "lti",
    "lti_inverse", "digitized-deadzone", "preisach", "preisach-inverse", "bouc-wen",
    "bouc-wen-inverse", "rate-preisach", "rate-preisach-inverse", "stop-pi", "diag-friction-gap",
    "menegotto-pinto", "menegotto-pinto-inverse",
}
CASES: dict[str, Model] = {**ZOO, **DIAGNOSED}


def _input(seed: int) -> np.ndarray:
    return turning_points(seed, N)


def _case(i: int, name: str, inv: bool, fwd: bool) -> str:
    n = f"c{i}"
    decl = []
    if inv:
        decl += [f"{n}_inv_state si;", f"{n}_inv_init(&si);"]
    if fwd:
        decl += [f"{n}_fwd_state sr, sf;", f"{n}_fwd_init(&sr);", f"{n}_fwd_init(&sf);"]
    body = [
        f"out[0] = {f'{n}_inv_step(&si, buf[k])' if inv else '0.0'};",
        f"out[1] = {f'{n}_fwd_step(&sr, out[0])' if inv and fwd else '0.0'};",
        f"out[2] = {f'{n}_fwd_step(&sf, buf[k])' if fwd else '0.0'};",
    ]
    return "\n".join([
        f"    case {i}: {{ /* {name} */", *(f"        {d}" for d in decl),
        "        for (k = 0; k < n; ++k) {", "            double out[3];",
        *(f"            {b}" for b in body),
        "            fwrite(out, sizeof(double), 3, stdout);", "        }", "        break; }",
    ])


@pytest.fixture(scope="module")
def program(tmp_path_factory) -> tuple[Path, dict[str, tuple[int, bool, bool, int]]]:
    if GCC is None:
        pytest.skip("gcc not installed")
    d = tmp_path_factory.mktemp("c_all")
    info: dict[str, tuple[int, bool, bool, int]] = {}
    cases, includes, sources = [], [], []
    for i, (name, model) in enumerate(CASES.items()):
        fwd = name != "advance"  # an advance needs the future: only its inverse is causal
        code = generate_c(model, f"c{i}", inverse=True, forward=fwd, dt=DT)
        code.write(d)
        preview = int(code.header.split(f"#define C{i}_INV_PREVIEW ")[1].split()[0])
        info[name] = (i, True, fwd, preview)
        includes.append(f'#include "c{i}.h"')
        sources.append(str(d / f"c{i}.c"))
        cases.append(_case(i, name, True, fwd))
    driver = "\n".join([
        "#include <stdio.h>", "#include <stdlib.h>", *includes, "",
        "static double buf[200000];", "",
        "int main(int argc, char **argv)", "{",
        "    size_t n = fread(buf, sizeof(double), 200000, stdin);", "    size_t k;",
        "    if (argc < 2) return 2;", "    switch (atoi(argv[1])) {", *cases,
        "    default: return 3;", "    }", "    return 0;", "}", "",
    ])
    (d / "driver.c").write_text(driver)
    exe = d / "drv"
    proc = subprocess.run([GCC, *CFLAGS, "-o", str(exe), str(d / "driver.c"), *sources, "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[:4000]
    return exe, info


def _run(exe: Path, i: int, u: np.ndarray) -> np.ndarray:
    res = subprocess.run([str(exe), str(i)], input=u.astype("<f8").tobytes(),
                         capture_output=True)
    assert res.returncode == 0
    return np.frombuffer(res.stdout, dtype="<f8").reshape(-1, 3)


@pytest.mark.parametrize("name", sorted(CASES))
def test_c_matches_python_both_directions_and_round_trips(program, name) -> None:
    exe, info = program
    i, _, fwd, preview = info[name]
    model = CASES[name]
    u = _input(i)
    assert u.size == N
    out = _run(exe, i, u)
    inv_c, rt_c, fwd_c = out.T
    form = causal_form(model.inverse(), DT)
    assert form.preview == preview
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # inverse maps may clip; C counts the same samples
        inv_py = form.model(u, dt=DT)
    scale = max(1.0, float(np.ptp(inv_py)))
    np.testing.assert_allclose(inv_c, inv_py, rtol=0, atol=1e-9 * scale)
    if not fwd:
        return
    y_py = model(u, dt=DT)
    np.testing.assert_allclose(fwd_c, y_py, rtol=0, atol=1e-9 * max(1.0, float(np.ptp(y_py))))
    rt_py = model(inv_py, dt=DT)
    np.testing.assert_allclose(rt_c, rt_py, rtol=0, atol=1e-9 * max(1.0, float(np.ptp(rt_py))))
    if name in EXACT:  # forward(inverse(u)) == u in C
        np.testing.assert_allclose(rt_c, u, rtol=0, atol=1e-9 * max(1.0, float(np.ptp(u))))
    elif preview:  # the round trip is u, `preview` samples late (the stated bound)
        e = np.abs(rt_c[preview:] - u[:-preview])
        assert np.median(e) < 1e-3 * float(np.ptp(u)), name
    else:  # approximate inverses: resonance roll-off, digitized grids
        assert np.median(np.abs(rt_c - u)) < 0.02 * float(np.ptp(u)), name


def test_every_registered_type_has_an_instance_and_a_c_emitter() -> None:
    types = model_types()
    assert {t.name for t in types} == set(ZOO)
    assert [t.name for t in types if not t.c_export] == []


def test_a_type_without_emitter_gets_a_clear_error() -> None:
    from dataclasses import dataclass
    from typing import Any, ClassVar

    @dataclass(frozen=True, eq=False)
    class Saturation(Model):
        type_name: ClassVar[str] = "made-up-saturation"

        def _run(self, u: Any, state: Any, dt: float | None) -> tuple[Any, Any]:
            return u, state

        def default_state(self) -> None:
            return None

    with pytest.raises(CExportError, match=r"model type 'made-up-saturation' \(stage 1 of the "
                       r"forward model\) is not supported; supported stage types: .*creep"):
        generate_c(Chain.of(PIModel(1.0, [0.5], [0.2]), Saturation()), inverse=False)


def test_preview_is_exposed_and_needs_dt() -> None:
    code = generate_c(Chain.of(EX1, Delay(2.5e-4)), "cmp", dt=DT)
    assert "#define CMP_INV_PREVIEW 3" in code.header
    assert "feed the desired output 3 sample(s)" in code.header
    with pytest.raises(CExportError, match="needs the sample time to size its preview"):
        generate_c(Chain.of(EX1, Delay(2.5e-4)), "cmp")
