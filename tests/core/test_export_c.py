"""Generated C code is compiled with gcc and checked against the Python models."""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from core.base import Chain, Model
from core.exceptions import NotInvertibleError
from core.export_c import (
    CExportError,
    c_double,
    c_identifier,
    export_c,
    generate_c,
    supported_c_types,
)
from core.paramset import ParameterSet
from core.pi import PIModel

GCC = shutil.which("gcc")
needs_gcc = pytest.mark.skipif(GCC is None, reason="gcc not installed: cannot compile C export")
CFLAGS = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2"]

# Paper 001, Example 1.
EX1 = PIModel(0.72, [0.45 * i for i in range(1, 7)], [0.6, 0.48, 0.36, 0.24, 0.12, 0.012])

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "NAME.h"

/* stdin: n doubles. stdout per sample: inv(u), fwd(inv(u)), fwd(u); then a reset check. */
int main(void)
{
    static double buf[200000];
    size_t n = fread(buf, sizeof(double), 200000, stdin);
    size_t k;
    NAME_inv_state si;
    NAME_fwd_state sr, sf;
    double first[3], again[3];
    NAME_inv_init(&si);
    NAME_fwd_init(&sr);
    NAME_fwd_init(&sf);
    for (k = 0; k < n; ++k) {
        double out[3];
        out[0] = NAME_inv_step(&si, buf[k]);
        out[1] = NAME_fwd_step(&sr, out[0]);
        out[2] = NAME_fwd_step(&sf, buf[k]);
        if (k == 0) { first[0] = out[0]; first[1] = out[1]; first[2] = out[2]; }
        fwrite(out, sizeof(double), 3, stdout);
    }
    /* reset must restore the initial state: the first sample gives the same outputs */
    NAME_inv_reset(&si);
    NAME_fwd_reset(&sr);
    NAME_fwd_reset(&sf);
    again[0] = NAME_inv_step(&si, buf[0]);
    again[1] = NAME_fwd_step(&sr, again[0]);
    /* the block function must equal repeated steps */
    NAME_fwd_reset(&sf);
    NAME_fwd_run(&sf, buf, buf, 1);
    again[2] = buf[0];
    fwrite(again, sizeof(double), 3, stdout);
    (void)first;
    return 0;
}
"""


def reversal_input(rng: np.random.Generator, n: int, amp: float) -> np.ndarray:
    """Piecewise-linear input through random turning points (nested minor loops)."""
    out, total, a = [], 0, 0.0
    while total < n:
        b = float(rng.uniform(-amp, amp))
        m = int(rng.integers(5, 75))
        out.append(np.linspace(a, b, m, endpoint=False))
        total, a = total + m, b
    return np.concatenate(out)[:n]


def build_and_run(
    tmp: Path, model: Model | ParameterSet, name: str, u: np.ndarray, dt: float | None = None
) -> np.ndarray:
    """Generate, compile with gcc and run; returns (N+1, 3) outputs (last row: reset check)."""
    code = generate_c(model, name, dt=dt)
    code.write(tmp)
    (tmp / "driver.c").write_text(DRIVER.replace("NAME", name))
    exe = tmp / "drv"
    proc = subprocess.run(
        [GCC, *CFLAGS, "-o", str(exe), str(tmp / "driver.c"), str(tmp / f"{name}.c"), "-lm"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    res = subprocess.run([str(exe)], input=u.astype("<f8").tobytes(), capture_output=True)
    assert res.returncode == 0
    return np.frombuffer(res.stdout, dtype="<f8").reshape(-1, 3)


@needs_gcc
def test_pi_compensator_matches_python_on_1e5_random_reversals(tmp_path, rng):
    u = reversal_input(rng, 100_000, 10.0)
    assert u.size == 100_000
    out = build_and_run(tmp_path, EX1, "ex1", u)
    inv_c, round_trip_c, fwd_c = out[:-1].T
    inv_py = EX1.inverse()(u)
    np.testing.assert_allclose(inv_c, inv_py, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fwd_c, EX1(u), rtol=0, atol=1e-9)
    # the compensator cancels the hysteresis in C: forward(inverse(u)) == u
    np.testing.assert_allclose(round_trip_c, u, rtol=0, atol=1e-9)
    # and it really is hysteretic (not the identity)
    assert np.max(np.abs(inv_c - u / EX1.slopes[-1])) > 0.1
    # reset restores the initial state; _run equals _step
    np.testing.assert_array_equal(out[-1], [inv_c[0], round_trip_c[0], fwd_c[0]])


@needs_gcc
def test_chain_with_initial_state_matches_python(tmp_path, rng):
    a = PIModel(0.5, [0.2, 0.7, 1.5], [0.3, 0.2, 0.1], state0=[0.1, -0.3, 0.4])
    b = PIModel(1.2, [0.3, 1.0], [0.4, -0.2])
    model = Chain.of(a, b)
    u = reversal_input(rng, 20_000, 6.0)
    ps = ParameterSet.from_model(model, source="test chain */ with comment end")
    out = build_and_run(tmp_path, ps, "chain2", u)
    inv_c, round_trip_c, fwd_c = out[:-1].T
    np.testing.assert_allclose(inv_c, model.inverse()(u), rtol=0, atol=1e-9)
    np.testing.assert_allclose(fwd_c, model(u), rtol=0, atol=1e-9)
    np.testing.assert_allclose(round_trip_c, u, rtol=0, atol=1e-9)


def test_constants_are_emitted_with_full_precision():
    code = generate_c(EX1, "p")
    q0, z, q = 1 / 0.72, EX1.inverse().thresholds, EX1.inverse().weights
    assert c_double(q0) in code.source
    for v in [*z, *q]:
        assert c_double(v) in code.source
        assert float(c_double(v)) == v
    assert c_double(0.1) == "0.10000000000000001"
    assert c_double(3.0) == "3.0"
    for v in np.random.default_rng(1).standard_normal(200) * 10.0 ** np.arange(-100, 100):
        assert float(c_double(v)) == v


def test_header_declares_the_api_and_only_requested_blocks():
    code = generate_c(EX1, "piezo", forward=False)
    assert code.blocks == ("piezo_inv",)
    for decl in (
        "void piezo_inv_init(piezo_inv_state *st);",
        "void piezo_inv_reset(piezo_inv_state *st);",
        "double piezo_inv_step(piezo_inv_state *st, double u);",
        "void piezo_inv_run(piezo_inv_state *st, const double *u, double *y, size_t n);",
    ):
        assert decl in code.header
    assert "piezo_fwd" not in code.header
    assert "malloc" not in code.source
    assert code.header.count("#ifndef PIEZO_H_INCLUDED") == 1


def test_export_c_writes_header_and_source_named_after_path(tmp_path):
    h, c = export_c(EX1, tmp_path / "sub" / "my-comp.c")
    assert h.name == "my-comp.h" and c.name == "my-comp.c"
    assert '#include "my-comp.h"' in c.read_text()
    assert "double my_comp_inv_step(" in h.read_text()
    assert c_identifier("2nd stage") == "h_2nd_stage"


def test_errors_are_clear():
    with pytest.raises(CExportError, match="not a valid C identifier"):
        generate_c(EX1, "bad-name")
    with pytest.raises(CExportError, match="nothing to generate"):
        generate_c(EX1, inverse=False, forward=False)
    bad = PIModel(1.0, [1.0, 2.0], [-1.0, 0.5])
    with pytest.raises(NotInvertibleError, match="S2"):
        generate_c(bad)
    # the forward model alone is fine even when not invertible
    assert "hyst_fwd_step" in generate_c(bad, inverse=False).source

    @dataclass(frozen=True, eq=False)
    class Unknown(Model):
        type_name: ClassVar[str] = "made-up"

        def _run(self, u: Any, state: Any, dt: float | None) -> tuple[Any, Any]:
            return u, state

        def default_state(self) -> None:
            return None

        def to_dict(self) -> dict[str, Any]:
            return {"type": self.type_name}

        @classmethod
        def from_dict(cls, d: dict[str, Any]) -> Unknown:
            return cls()

    with pytest.raises(CExportError, match=r"'made-up' \(stage 1 of the forward model\)"):
        generate_c(Chain.of(EX1, Unknown()), inverse=False)
    assert "pi" in supported_c_types()


# ----------------------------------------------------------------------------- other stages
def _other_models() -> dict[str, tuple[Model, float, bool]]:
    """name -> (model, input amplitude, exact inverse); built from the modules that exist."""
    out: dict[str, tuple[Model, float, bool]] = {}
    from core.stages import Offset

    out["pi_offset"] = (Chain.of(EX1, Offset(0.25)), 8.0, True)
    try:
        from core.deadzone import DeadZoneMap
        from core.gpi import DeadZoneGPI, ModifiedPI, TanhEnvelope, TanhGPI, paper001_example6
    except ImportError:  # pragma: no cover - before the GPI modules exist
        return out
    g = DeadZoneMap.symmetric([0.8, 1.6, 2.5], 0.9, [0.4, -0.3, 0.2])
    out["deadzone"] = (g, 4.0, True)
    out["gpi_deadzone"] = (DeadZoneGPI(EX1, g), 3.0, True)
    out["mpi"] = (ModifiedPI(EX1, g), 3.0, True)
    out["gpi_tanh"] = (paper001_example6(), 8.0, True)
    # counter-clockwise envelope (kappa_R <= kappa_L): the compensator is still exact
    env = TanhEnvelope([6.0, 0.4, 0.0, -0.2], [6.0, 0.4, 0.0, 0.2])
    out["gpi_tanh_2"] = (TanhGPI(PIModel(0.3, [0.5, 1.0], [0.2, 0.1]), env), 4.0, True)
    try:
        from core.digitized import DigitizedPI
    except ImportError:  # pragma: no cover
        return out
    out["digitized"] = (DigitizedPI.from_pi(EX1, (-8.0, 8.0), refine=2), 8.0, False)
    try:
        from core.digitized_deadzone import DigitizedDeadZone, DigitizedModifiedPI
    except ImportError:  # pragma: no cover
        return out
    dzd = DigitizedDeadZone([1.0, 2.0, 3.0, 2.0], [2.0, 1.0, 0.5, 1.5], x0=-4.0, y0=-5.0)
    out["digitized_deadzone"] = (dzd, 6.0, True)
    dpi = DigitizedPI.from_pi(PIModel(0.6, [0.5, 1.0], [0.3, 0.2]), (-4.0, 4.0))
    out["digitized_mpi"] = (DigitizedModifiedPI(dpi, dzd), 4.0, False)
    return out


OTHER = _other_models()


@needs_gcc
@pytest.mark.parametrize("key", sorted(OTHER))
def test_other_stage_types_match_python(key, tmp_path, rng):
    import warnings

    model, amp, exact = OTHER[key]
    u = reversal_input(rng, 20_000, amp)
    y_ref = model(u)
    # keep the compensator's input inside the forward model's range (tanh domain)
    u = np.clip(u, np.min(y_ref) * 0.95, np.max(y_ref) * 0.95) if "tanh" in key else u
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the Python inverse must not clip on this input
        inv_py = model.inverse()(u)
    out = build_and_run(tmp_path, model, f"m_{key}", u)
    inv_c, round_trip_c, fwd_c = out[:-1].T
    scale = max(1.0, float(np.max(np.abs(u))))
    np.testing.assert_allclose(fwd_c, model(u), rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(inv_c, inv_py, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(round_trip_c, model(inv_py), rtol=0, atol=1e-9 * scale)
    if exact:
        np.testing.assert_allclose(round_trip_c, u, rtol=0, atol=1e-9 * scale)
    np.testing.assert_array_equal(out[-1], [inv_c[0], round_trip_c[0], fwd_c[0]])


@needs_gcc
def test_linear_dynamics_with_baked_in_dt(tmp_path, rng):
    from core.lti import LinearSystem

    g = LinearSystem([0.5, 1.0], [0.01, 1.0])  # biproper, minimum phase: invertible
    model = Chain.of(EX1, g)
    dt = 1e-4
    u = reversal_input(rng, 20_000, 6.0)
    out = build_and_run(tmp_path, model, "dyn", u, dt=dt)
    inv_c, round_trip_c, fwd_c = out[:-1].T
    np.testing.assert_allclose(fwd_c, model(u, dt=dt), rtol=0, atol=1e-9)
    np.testing.assert_allclose(inv_c, model.inverse()(u, dt=dt), rtol=0, atol=1e-9)
    np.testing.assert_allclose(round_trip_c, u, rtol=0, atol=1e-9)
    with pytest.raises(CExportError, match="has dynamics .*give the sample time"):
        generate_c(model)
    strictly_proper = Chain.of(EX1, LinearSystem([1.0], [0.01, 1.0]))
    assert "dt = 0.001" in generate_c(strictly_proper, inverse=False, dt=1e-3).source
