"""The C compensator of a diagnosed chain with a delay against Python's inverse (issue 32
item 4).

The inverse of a delay is an advance: Python's ``model.inverse()`` (``hyst invert``, ``hyst
simulate --inverse``) reads the known trajectory ahead, while the C compensator is causal
(:func:`core.stages.causal_form`): fed the desired output from its first sample, its output
at step ``j`` is the inverse at sample ``j - P`` (``P = <NAME>_INV_PREVIEW``). Compared at the
same sample index the two differ by the trajectory's change over ``P`` samples: 0.47 % of the
range here, 4.4 % with a lag before the delay (the issue's 0.76 % on its trajectory); at
``j - P`` they agree to round-off. Every layout the diagnosis writes with a delay is covered
(initial memory, asymmetry, creep, lag, a lightly damped mode, delay, offset, drift; PI,
rate-dependent PI, Preisach and Bouc-Wen bases; fractional and whole-sample delays); all
compiled into one program.
"""

from __future__ import annotations

import shutil
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

from core.base import Chain, Model
from core.export_c import generate_c
from core.stages import (
    Asymmetry,
    Creep,
    Delay,
    Drift,
    InitialMemory,
    Lag,
    Offset,
    RateDependentPI,
    Resonance,
    causal_form,
)
from tests.core.model_zoo import BOUC_WEN, DT, EX1, PREISACH

GCC = shutil.which("gcc")
N = 4000
REST = 10  # samples at rest before the trajectory moves (>= every preview here)
SPAN = N * DT


def _layout(base: Model, *dynamics: Model) -> Model:
    """The chain ``hyst diagnose`` writes with every effect on (core.diagnosis.structure)."""
    return Chain.of(base, Asymmetry([0.1, 0.02], 0.5, 2.0),
                    Creep([0.01, 0.1, 1.0], [0.02, 0.01, 0.03]), *dynamics, Offset(0.2),
                    Drift([0.1, -0.05], SPAN))


CASES: dict[str, Model] = {
    "pi-delay": _layout(InitialMemory(EX1, [2.0, -1.0]), Delay(2.5e-4)),
    "pi-whole-delay": _layout(InitialMemory(EX1, [2.0, -1.0]), Delay(3e-4)),
    "pi-lag-delay": _layout(InitialMemory(EX1, [2.0, -1.0]), Lag(1e-3), Delay(2.5e-4)),
    "pi-mode-delay": _layout(InitialMemory(EX1, [2.0, -1.0]), Resonance(180.0, 0.08),
                             Delay(2.5e-4)),
    "rate-delay": _layout(InitialMemory(RateDependentPI(EX1.p0, EX1.thresholds, EX1.weights,
                                                        2e-5), [2.0, -1.0]), Delay(3.7e-4)),
    "preisach-delay": _layout(InitialMemory(PREISACH, [2.5, -1.5]), Delay(2.5e-4)),
    "bouc-wen-delay": _layout(BOUC_WEN, Delay(6.3e-4)),
}


def _desired(model: Model) -> np.ndarray:
    """A desired output inside the model's range, at rest over the first ``REST`` samples."""
    t = np.arange(N - REST) * DT
    u = np.r_[np.zeros(REST), 3.0 * np.sin(2 * np.pi * 5 * t) * np.exp(-t / 0.5)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return model(u, dt=DT)


@pytest.fixture(scope="module")
def program(tmp_path_factory) -> tuple[Path, dict[str, int]]:
    if GCC is None:
        pytest.skip("gcc not installed")
    d = tmp_path_factory.mktemp("c_preview")
    cases, includes, sources, previews = [], [], [], {}
    for i, (name, model) in enumerate(CASES.items()):
        code = generate_c(model, f"p{i}", inverse=True, forward=False, dt=DT)
        code.write(d)
        previews[name] = int(code.header.split(f"#define P{i}_INV_PREVIEW ")[1].split()[0])
        includes.append(f'#include "p{i}.h"')
        sources.append(str(d / f"p{i}.c"))
        cases.append(f"    case {i}: {{ p{i}_inv_state s; p{i}_inv_init(&s); "
                     f"for (k = 0; k < n; ++k) buf[k] = p{i}_inv_step(&s, buf[k]); break; }}")
    (d / "driver.c").write_text("\n".join([
        "#include <stdio.h>", "#include <stdlib.h>", *includes,
        f"static double buf[{N}];",
        "int main(int argc, char **argv)", "{",
        f"    size_t n = fread(buf, sizeof(double), {N}, stdin), k;",
        "    if (argc < 2) return 2;", "    switch (atoi(argv[1])) {", *cases,
        "    default: return 3;", "    }", "    fwrite(buf, sizeof(double), n, stdout);",
        "    return 0;", "}", ""]))
    exe = d / "drv"
    proc = subprocess.run([GCC, "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2",
                           "-o", str(exe), str(d / "driver.c"), *sources, "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[:4000]
    return exe, previews


@pytest.mark.parametrize("name", list(CASES))
def test_the_c_compensator_is_pythons_inverse_preview_samples_later(program, name) -> None:
    exe, previews = program
    model = CASES[name]
    r = _desired(model)
    res = subprocess.run([str(exe), str(list(CASES).index(name))],
                         input=r.astype("<f8").tobytes(), capture_output=True, check=True)
    c = np.frombuffer(res.stdout, "<f8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        form = causal_form(model.inverse(), DT)
        causal = form.model(r, dt=DT)
        inverse = model.inverse()(r, dt=DT)  # reads the trajectory ahead
    p = previews[name]
    assert p == form.preview == model.inverse().preview_samples(DT) > 0
    scale = float(np.ptp(inverse))
    np.testing.assert_allclose(c, causal, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(c[p:], inverse[:-p], rtol=0, atol=1e-9 * scale)
    # the comparison: the same sample index, the compensator P samples late
    assert np.max(np.abs(c - inverse)) > 1e-3 * scale
