"""C99 and FMU export of the Menegotto-Pinto bank and its inverse (core/c_emit/nonmasing.py).

References: the Python models (``simulate`` and ``inverse().simulate``, run in chunks with
the state carried, as an embedded caller or an FMU steps), and two properties that hold
whatever either implementation does: the compensator returns the input that made a
forward output (the branches rise strictly), and the forward model of the compensator's
output is the desired output. Inputs: a bipolar history of growing amplitude with inner
loops (the non-Masing case: every excursion larger than the last) and random reversals.
The FMUs are stepped by an importer's loop (accumulated time, several samples per step)
through fmpy, retuned, refused bad values and reset. A hostile parameter set never reaches
the generated code: it is refused at load with the field named.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from fmpy.validation import validate_fmu

from core.base import Model
from core.export_c import CExportError, generate_c
from core.export_fmu import build_fmu
from core.nonmasing import MenegottoPintoModel
from core.paramset import ParameterSet, ParameterSetError, load_parameter_set
from tests.core.model_zoo import DT, turning_points
from tests.core.test_export_fmu_stepping import DISCARD, LoggedMaster

GCC = shutil.which("gcc")
needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc not installed: cannot compile C export")
CFLAGS = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2"]

#: Clockwise loops (w >= 0), three elements of different knees and roundings.
CLOCKWISE = MenegottoPintoModel(0.3, [0.25, 0.6, 1.2], [1.5, 0.8, 0.4], [20.0, 8.0, 3.0],
                                [0.9, 0.5, 0.0], [0.15, 0.5, 1.0])
#: Counter-clockwise loops (the smooth play form, w <= 0; smallest slope 0.4).
COUNTER = MenegottoPintoModel(1.4, [0.3, 0.8, 1.5], [-0.5, -0.3, -0.2], [15.0, 5.0, 30.0],
                              [0.925, 0.3, 0.6], [0.15, 1.0, 0.05])
#: One steel-like element (Filippou's constants; strain-sized input, yield 2e-3).
STEEL = MenegottoPintoModel(0.02, [2e-3], [0.98], [20.0], [0.925], [0.15])
#: Sharp knees (R0 at its largest: |e*|^R0 overflows a double past e* = 1.001).
SHARP = MenegottoPintoModel(0.3, [0.25, 0.6, 1.2], [1.5, 0.8, 0.4], [1e6, 1e6, 1e6],
                            [0.5, 0.5, 0.5], [0.15, 0.15, 0.15])
#: A bank that starts with memory (the diagnosis gives a recording's start as a history run
#: from rest): the C state at reset is the one the history leaves.
MEMORY = MenegottoPintoModel(0.3, [0.25, 0.6, 1.2], [1.5, 0.8, 0.4], [20.0, 8.0, 3.0],
                             [0.9, 0.5, 0.0], [0.15, 0.5, 1.0], history=[2.5, -1.7, 0.9])
MODELS: dict[str, tuple[MenegottoPintoModel, float]] = {  # model, input amplitude
    "clockwise": (CLOCKWISE, 3.0), "counter": (COUNTER, 3.0), "steel": (STEEL, 0.012),
    "sharp": (SHARP, 3.0), "memory": (MEMORY, 3.0)}
N = 20_000


def growing(n: int, amp: float) -> np.ndarray:
    """Bipolar cycles of growing amplitude (to ``amp``) with small inner loops."""
    t = np.linspace(0.0, 1.0, n)
    return amp * (t * np.sin(2 * np.pi * 8 * t) + 0.06 * np.sin(2 * np.pi * 53 * t))


def inputs(amp: float) -> dict[str, np.ndarray]:
    return {"growing": growing(N, amp), "random": amp / 3.0 * turning_points(17, N)}


#: Chunk lengths of the C runs and of the Python runs (state carried between them).
C_CHUNKS = (1, 7, 2, 311, 3, 64)
PY_CHUNKS = (977, 1, 13, 4096)


def chunked_python(model: Model, u: np.ndarray) -> np.ndarray:
    """``model.simulate`` in chunks of :data:`PY_CHUNKS` lengths, each from the state the
    previous one left."""
    out, state, k, i = [], None, 0, 0
    while k < u.size:
        m = PY_CHUNKS[i % len(PY_CHUNKS)]
        r = model.simulate(u[k:k + m], state=state)
        out.append(r.y)
        state, k, i = r.state, k + m, i + 1
    return np.concatenate(out)


_DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
INCLUDES

static double buf[200000], out[200000];
static const size_t chunks[] = {CHUNKS};

/* argv[1]: block number (2 j: model j forward, 2 j + 1: its compensator); stdin: n doubles;
   stdout: the block's outputs, run through <block>_run in chunks of the lengths above
   with one state, then the forward model of those outputs (one more state). */
int main(int argc, char **argv)
{
    size_t n = fread(buf, sizeof(double), 200000, stdin), k = 0, c = 0, m;
    if (argc < 2) return 2;
    switch (atoi(argv[1])) {
CASES
    default: return 3;
    }
    fwrite(out, sizeof(double), n, stdout);
    return 0;
}
"""


def _case(j: int, inverse: bool) -> str:
    blk = f"mp{j}_{'inv' if inverse else 'fwd'}"
    return "\n".join([
        f"    case {2 * j + int(inverse)}: {{",
        f"        {blk}_state st;",
        f"        mp{j}_fwd_state sf;",
        f"        {blk}_init(&st);",
        "        while (k < n) {",
        "            m = chunks[c++ % (sizeof chunks / sizeof chunks[0])];",
        "            if (m > n - k) m = n - k;",
        f"            {blk}_run(&st, buf + k, out + k, m);",
        "            k += m;",
        "        }",
        "        fwrite(out, sizeof(double), n, stdout);",
        f"        mp{j}_fwd_init(&sf);",
        f"        mp{j}_fwd_run(&sf, out, out, n);",
        "        break; }",
    ])


@pytest.fixture(scope="module")
def program(tmp_path_factory) -> Path:
    if GCC is None:
        pytest.skip("gcc not installed")
    d = tmp_path_factory.mktemp("mp_c")
    includes, sources, cases = [], [], []
    for j, (model, _) in enumerate(MODELS.values()):
        generate_c(model, f"mp{j}").write(d)
        includes.append(f'#include "mp{j}.h"')
        sources.append(str(d / f"mp{j}.c"))
        cases += [_case(j, False), _case(j, True)]
    driver = (_DRIVER.replace("INCLUDES", "\n".join(includes))
              .replace("CHUNKS", ", ".join(f"{m}u" for m in C_CHUNKS))
              .replace("CASES", "\n".join(cases)))
    (d / "driver.c").write_text(driver)
    exe = d / "drv"
    proc = subprocess.run([GCC, *CFLAGS, "-o", str(exe), str(d / "driver.c"), *sources, "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[:4000]
    return exe


def _run_c(exe: Path, block: int, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    res = subprocess.run([str(exe), str(block)], input=u.astype("<f8").tobytes(),
                         capture_output=True, check=True)
    out = np.frombuffer(res.stdout, dtype="<f8")
    return out[:u.size], out[u.size:]  # the block's outputs, the forward model of them


def _close(got: np.ndarray, ref: np.ndarray, what: str) -> None:
    scale = float(np.ptp(ref))
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9 * scale, err_msg=what)


@pytest.mark.parametrize("signal", ["growing", "random"])
@pytest.mark.parametrize("name", list(MODELS))
def test_c_forward_and_compensator_match_python_in_chunks(program, name, signal) -> None:
    model, amp = MODELS[name]
    j = list(MODELS).index(name)
    u = inputs(amp)[signal]
    y_py = model.simulate(u).y
    _close(chunked_python(model, u), y_py, "Python in chunks")
    y_c, _ = _run_c(program, 2 * j, u)
    _close(y_c, y_py, "C forward")
    # the compensator of the forward output: Python's, and the input that made it
    v_py = model.inverse().simulate(y_py).y
    _close(chunked_python(model.inverse(), y_py), v_py, "Python compensator in chunks")
    v_c, back = _run_c(program, 2 * j + 1, y_py)
    _close(v_c, v_py, "C compensator")
    _close(v_c, u, "C compensator returns the input")
    _close(back, y_py, "C forward of the C compensator")
    # a desired output held three samples: the compensator's input stays where it was
    held, _ = _run_c(program, 2 * j + 1, np.repeat(y_py, 3))
    _close(held[2::3], v_c, "C compensator with held samples")
    _close(model.inverse().simulate(np.repeat(y_py, 3)).y[2::3], v_py,
           "Python compensator with held samples")


def test_the_history_matters_so_the_comparison_can_fail() -> None:
    """The growing history is non-Masing for the models with a curvature drop: the same
    bank without it (Masing) differs by far more than the tolerance."""
    for name in ("clockwise", "counter", "steel"):
        model, amp = MODELS[name]
        masing = MenegottoPintoModel(model.k, model.thresholds, model.weights, model.curvature,
                                     np.zeros(model.n), model.curvature_scale)
        u = growing(N, amp)
        y = model(u)
        assert np.max(np.abs(y - masing(u))) > 1e-3 * np.ptp(y), name


def test_an_inverse_whose_slopes_overflow_is_refused_with_words() -> None:
    big = MenegottoPintoModel(1.0, [0.5, 1.0], [1e308, 1e308], [10.0, 10.0], [0.5, 0.5],
                              [0.2, 0.2])
    code = generate_c(big, "big", inverse=False)  # the forward model runs (to inf outputs)
    assert "1e+308" in code.source
    with np.errstate(over="ignore"), \
            pytest.raises(CExportError, match=r"overflow a double; scale k and the weights down"):
        generate_c(big, "big")


# ----------------------------------------------------------------------------- hostile
_PAYLOAD = '20); } int PWNED(void) { system("id"); return 0; } static double x = (1'


@pytest.mark.parametrize(("field", "value", "words"), [
    ("k", "NaN", r"JSON contains NaN; every parameter must be a finite number"),
    ("k", "Infinity", r"JSON contains Infinity; every parameter must be a finite number"),
    ("k", "1e999", r"model\.k: must be a finite number, got inf"),
    ("curvature", json.dumps([_PAYLOAD, 8.0, 3.0]),
     r"model\.curvature\[0\]: must be a number, got a string"),
    ("thresholds", json.dumps("*/ int PWNED; /*"),
     r"model\.thresholds: must be an array of numbers, got a string"),
    ("weights", json.dumps([1.5, {"x": "PWNED"}, 0.4]), r"model\.weights\[1\]: must be a number"),
    ("curvature", "[1e300, 8, 3]", r"model\.curvature\[0\] = 1e\+300 must be <= 1e\+06"),
    ("curvature_scale", "[0.15, -0.5, 1]", r"model\.curvature_scale.*> 0"),
    ("curvature_drop", "[1, 0.5, 0]", r"model\.curvature_drop\[0\] = 1 must be < 1"),
])
def test_a_hostile_parameter_set_is_refused_at_load_with_the_field_named(field, value,
                                                                         words) -> None:
    doc = ParameterSet.from_model(CLOCKWISE).to_dict()
    doc["model"][field] = "@@"
    text = json.dumps(doc).replace('"@@"', value)
    with pytest.raises(ParameterSetError, match=words):
        load_parameter_set(text)


def test_every_number_in_the_code_is_a_parameter_written_exactly() -> None:
    """The constants of the generated code are the model's numbers (and the slope bounds
    derived from them) as exact double literals: nothing else of a parameter set is in it
    but the header's comment."""
    code = generate_c(CLOCKWISE, "mp0")
    body = code.source
    lits = re.findall(r"static const double mp0_(?:inv|fwd)_s0_(\w+)(?:\[\d+\])? = "
                      r"\{?\s*([^;}]*)\}?;", body)
    got: dict[str, list[float]] = {}
    for name, text in lits:
        got.setdefault(name, []).append(
            [float(v) for v in text.replace("\n", " ").split(",")])  # type: ignore[arg-type]
    m = CLOCKWISE
    expect = {"K": [m.k], "R": m.thresholds, "W": m.weights, "C0": m.curvature,
              "C1": m.curvature_drop, "C2": m.curvature_scale, "MLO": [m.slope_bounds()[0]],
              "MHI": [m.slope_bounds()[1]]}
    assert set(got) == set(expect)
    for name, values in got.items():
        for v in values:  # once per block that has it
            assert v == list(np.asarray(expect[name], dtype=float)), name


# ----------------------------------------------------------------------------- FMU
# (fmpy is a dev dependency: imported at the top, so that a missing one fails the module
# instead of skipping its C tests with it)


def _stepped(m: LoggedMaster, x: np.ndarray, per: int, t: float) -> tuple[np.ndarray, float]:
    """An importer's loop from time ``t``: the input set, ``doStep(t, per dt)`` with its own
    accumulated time ``t += per dt``, the output read; the outputs and the time reached."""
    y, h = np.empty(x.size), per * DT
    for k, v in enumerate(x.tolist()):
        m.set(v)
        m.step(t, h)
        t += h
        y[k] = m.get()
    return y, t


def _held(model: Model, x: np.ndarray, per: int, state=None):
    """Python: each value held ``per`` samples; the output at each hold's last sample and
    the state after it."""
    r = model.simulate(np.repeat(x, per), state=state)
    return r.y[per - 1::per], r.state


@pytest.mark.parametrize("version", [3, 2])
@pytest.mark.parametrize("inverse", [False, True], ids=["model", "compensator"])
def test_fmu_stepped_retuned_refused_and_reset(tmp_path, version, inverse) -> None:
    if GCC is None:
        pytest.skip("gcc not installed")
    model = COUNTER
    fmu = build_fmu(model, tmp_path / "mp.fmu", fmi_version=version, inverse=inverse, dt=DT)
    assert validate_fmu(str(fmu)) == []
    base = "menegotto_pinto_inverse.model." if inverse else "menegotto_pinto."
    u = growing(1500, 3.0)
    x = model(u) if inverse else u  # a compensator is fed the forward model's outputs
    running = model.inverse() if inverse else model
    m = LoggedMaster(fmu, tmp_path / "x")
    m.start()
    per, k = 3, 900  # steps of three samples: the input held
    first, t = _stepped(m, x[:k], per, 0.0)
    ref1, state = _held(running, x[:k], per)
    scale = float(np.ptp(ref1))
    np.testing.assert_allclose(first, ref1, rtol=0, atol=1e-9 * scale)
    # a value the model refuses (Python: cR1 at most the slider's 0.99; the compensator: a
    # falling branch) is refused by the FMU too, and the old one kept
    bad, value = ("weights[1]", -2.0) if inverse else ("curvature_drop[1]", 1.0)
    status, msg = m.refused(m.set_named, {base + bad: value})
    assert status == DISCARD
    assert ("beyond what this export can run" if inverse else "must be at most 0.98") in msg
    assert m.get_named(base + bad) == (model.weights[0] if inverse else model.curvature_drop[0])
    # retune the first element's rounding from the state reached
    m.set_named({base + "curvature_drop[1]": 0.5, base + "curvature_scale[1]": 0.4})
    second, _ = _stepped(m, x[k:], per, t)
    tuned = MenegottoPintoModel(model.k, model.thresholds, model.weights, model.curvature,
                                [0.5, *model.curvature_drop[1:]],
                                [0.4, *model.curvature_scale[1:]])
    ref2, _ = _held(tuned.inverse() if inverse else tuned, x[k:], per, state)
    old, _ = _held(running, x[k:], per, state)
    assert np.max(np.abs(ref2 - old)) > 1e-4 * scale  # the change matters
    np.testing.assert_allclose(second, ref2, rtol=0, atol=1e-9 * scale)
    m.fmu.reset()  # the exported parameters and the virgin state
    m.start()
    again, _ = _stepped(m, x[:300], 1, 0.0)
    np.testing.assert_allclose(again, running.simulate(x[:300]).y, rtol=0, atol=1e-9 * scale)
    m.close()


@pytest.mark.parametrize("inverse", [False, True], ids=["model", "compensator"])
def test_fmu_of_a_bank_with_memory_starts_where_its_history_leaves_it(tmp_path,
                                                                       inverse) -> None:
    """The FMU of a bank that starts with memory (a history run from rest) starts, and
    restarts after a reset, from the state that history leaves, as Python's model."""
    if GCC is None:
        pytest.skip("gcc not installed")
    model = MEMORY
    fmu = build_fmu(model, tmp_path / "mp.fmu", fmi_version=3, inverse=inverse, dt=DT)
    assert validate_fmu(str(fmu)) == []
    u = growing(600, 2.0)
    x = model(u) if inverse else u
    running = model.inverse() if inverse else model
    want = running.simulate(x).y
    virgin = MenegottoPintoModel(model.k, model.thresholds, model.weights, model.curvature,
                                 model.curvature_drop, model.curvature_scale)
    scale = float(np.ptp(want))
    # the memory matters: the same bank from rest answers otherwise
    assert np.max(np.abs((virgin.inverse() if inverse else virgin).simulate(x).y - want)) \
        > 1e-3 * scale
    m = LoggedMaster(fmu, tmp_path / "x")
    for _ in range(2):  # first use, then after a reset
        m.start()
        got, _ = _stepped(m, x, 1, 0.0)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * scale)
        m.fmu.reset()
    m.close()
