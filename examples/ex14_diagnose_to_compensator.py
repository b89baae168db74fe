"""From diagnosis to compensator: concealed creep (and resonance) found, inverted, tracked.

A piezo-like plant (a PI model, 9 plays, ``p0 = 0.55``) hides a second effect: logarithmic
creep (5 lags, 0.01-100 s, 0.45 % of a step per decade) in one run, a lightly damped mode
(230 Hz, ζ = 0.05) in the other. Three recordings of each (a decaying 1 Hz sine, a multisine
1-100 Hz, a staircase with 2 s holds; white noise 0.02 µm) go through the command line as a
user would run it:

1. ``hyst diagnose REC*.csv --save-model ext.json`` names the effect and saves the extended
   model (PI + effect); ``hyst fit REC*.csv --model pi`` fits the PI-only model to the same
   recordings;
2. ``hyst invert`` turns each into a compensator (the creep inverse is exact, the resonance
   inverse has a roll-off at 4 f_n with a stated error bound);
3. ``hyst simulate --inverse`` computes the drive for a NEW desired trajectory (a staircase with
   holds for creep, a 15 + 40 Hz multisine for the resonance), and ``hyst export --format c``
   gives the same compensator in C99, compiled with gcc and run on the same trajectory (fed
   ``<NAME>_INV_PREVIEW`` samples ahead when the saved model has a delay, as the Python
   inverse reads the trajectory ahead, so both drives agree to round-off);
4. the true plant is driven with each drive; the tracking RMS error of the extended
   compensator is compared with the PI-only one's (goal: ratio <= 0.6).

Writes ``ex14_tracking.html`` (desired vs achieved output and the tracking error of both
compensators, both cases) and ``ex14_results.json`` (the RMS numbers, Python and C).

Run: ``python examples/ex14_diagnose_to_compensator.py [--out DIR]``. ``HYST_QUICK=1``
decimates the recordings and lets the diagnosis test only a few candidate effects.
"""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from _common import parse_out, quick, save

from app.cli import main as hyst
from core.base import Chain, Model
from core.pi import PIModel
from core.stages import Creep, Resonance

NOISE_UM = 0.02
CASES = {
    "creep": Creep([0.01, 0.1, 1.0, 10.0, 100.0], [0.0045] * 5),
    "resonance": Resonance(230.0, 0.05),
}
#: Effects the diagnosis may test in quick mode (the full run tests all of them).
QUICK_EFFECTS = {"creep": "creep,drift,lag", "resonance": "resonance,lag,delay"}


def truth_pi() -> PIModel:
    """The plant's hysteresis: 9 plays at 15..135 V, weights 0.12 exp(-0.02 r)."""
    r = np.arange(15.0, 136.0, 15.0)
    return PIModel(0.55, r, 0.12 * np.exp(-0.02 * r))


def recordings(decimate: int) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``(name, t, u)`` of the three excitations (time in s, drive in V)."""
    out = []
    fs = 2500.0
    t = np.arange(0, 6.0, 1 / fs)
    out.append(("decaying", t, 75.0 - 75.0 * np.exp(-t / 4.0) * np.cos(2 * np.pi * t)))
    fs = 5000.0
    segs = [75.0 - 75.0 * np.cos(2 * np.pi * f * np.arange(0, n / f, 1 / fs))
            for f, n in ((1.0, 2), (10.0, 10), (50.0, 25), (100.0, 40))]
    u = np.concatenate(segs)
    out.append(("multisine", np.arange(u.size) / fs, u))
    fs = 1000.0
    levels = [0, 30, 60, 90, 120, 150, 120, 90, 60, 30, 0]
    parts, prev = [], 0.0
    for lv in levels:
        parts += [np.linspace(prev, lv, 6)[1:], np.full(2000 - 5, float(lv))]
        prev = lv
    u = np.concatenate(parts)
    out.append(("staircase", np.arange(u.size) / fs, u))
    return [(n, t[::decimate], u[::decimate]) for n, t, u in out]


def desired(case: str, pi: PIModel) -> tuple[np.ndarray, np.ndarray]:
    """A new desired output trajectory (µm) inside the plant's range, and its time (s)."""
    if case == "creep":  # smooth steps with 1.5 s holds: creep shows while holding
        fs, levels = 1000.0, [20.0, 55.0, 35.0, 70.0, 45.0, 25.0]
        t = np.arange(0, 1.5 * len(levels), 1 / fs)
        k = np.minimum((t // 1.5).astype(int), len(levels) - 1)
        steps = np.asarray(levels)[k]
        w = np.exp(-0.5 * (np.arange(-60, 61) / 20.0) ** 2)
        yd = np.convolve(np.pad(steps, 60, mode="edge"), w / w.sum(), mode="valid")
        return t, yd
    fs = 5000.0  # resonance: a multisine well below the mode
    t = np.arange(0, 1.0, 1 / fs)
    ramp = np.minimum(t / 0.1, 1.0)
    y = 40.0 + ramp * (15.0 * np.sin(2 * np.pi * 15 * t) + 6.0 * np.sin(2 * np.pi * 40 * t))
    return t, y


def write_csv(path: Path, cols: dict[str, np.ndarray]) -> Path:
    np.savetxt(path, np.column_stack(list(cols.values())), delimiter=",",
               header=",".join(cols), comments="", fmt="%.12g")
    return path


def run_c(tmp: Path, model_json: Path, name: str, yd: np.ndarray, dt: float) -> np.ndarray:
    """Export the compensator to C, compile it with gcc and run it on ``yd``."""
    stem = tmp / name
    with contextlib.redirect_stdout(io.StringIO()):
        assert hyst(["export", str(model_json), "--format", "c", "-o", str(stem),
                     "--dt", f"{dt!r}", "--no-forward"]) == 0
    driver = tmp / f"{name}_main.c"
    driver.write_text("\n".join([
        "#include <stdio.h>", f'#include "{name}.h"', "static double buf[100000];",
        # a model with a delay needs the desired output PREVIEW samples ahead (the header
        # defines <NAME>_INV_PREVIEW then): call k gets desired[k + PREVIEW], held at the end
        f"#ifndef {name.upper()}_INV_PREVIEW", f"#define {name.upper()}_INV_PREVIEW 0", "#endif",
        "static double drive[100000];",
        "int main(void) {", "    size_t n = fread(buf, sizeof(double), 100000, stdin), k, j;",
        f"    {name}_inv_state st;", f"    {name}_inv_init(&st);",
        "    for (k = 0; k < n; ++k) {",
        f"        j = k + {name.upper()}_INV_PREVIEW < n ? k + {name.upper()}_INV_PREVIEW : n - 1;",
        f"        drive[k] = {name}_inv_step(&st, buf[j]);", "    }",
        "    fwrite(drive, sizeof(double), n, stdout);", "    return 0;", "}", ""]))
    exe = tmp / name
    subprocess.run([shutil.which("gcc") or "gcc", "-std=c99", "-pedantic", "-Wall", "-Wextra",
                    "-Werror", "-O2", "-o", str(exe), str(driver), f"{stem}.c", "-lm"],
                   check=True)
    res = subprocess.run([str(exe)], input=yd.astype("<f8").tobytes(), capture_output=True,
                         check=True)
    return np.frombuffer(res.stdout, dtype="<f8")


def rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x * x)))


def close_the_loop(case: str, tmp: Path, rng: np.random.Generator) -> dict:
    """Recordings -> diagnose -> invert -> track; the numbers of one case."""
    pi = truth_pi()
    plant: Model = Chain.of(pi, CASES[case])
    dec = 2 if quick() else 1
    files = []
    for name, t, u in recordings(dec):
        y = plant(u, dt=float(t[1] - t[0])) + NOISE_UM * rng.standard_normal(u.size)
        files.append(str(write_csv(tmp / f"{case}_{name}.csv", {"t_s": t, "u_V": u, "y_um": y})))
    ext, pio = tmp / f"{case}_ext.json", tmp / f"{case}_pi.json"
    diag = ["diagnose", *files, "--save-model", str(ext), "--json"]
    if quick():
        diag += ["--effects", QUICK_EFFECTS[case], "--operators", "15"]
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert hyst(diag) == 0
    found = [e["name"] for e in json.loads(buf.getvalue())["effects"]]
    with contextlib.redirect_stdout(io.StringIO()):
        assert hyst(["fit", *files, "--model", "pi", "-o", str(pio), "-q"]) == 0
    t, yd = desired(case, pi)
    dt = float(t[1] - t[0])
    yd_csv = write_csv(tmp / f"{case}_desired.csv", {"t": t, "u": yd})
    out: dict = {"effects_found": found, "desired_samples": int(yd.size), "dt_s": dt}
    traces = {}
    for label, model_json in (("extended", ext), ("pi_only", pio)):
        inv_json = tmp / f"{case}_{label}_inv.json"
        drive_csv = tmp / f"{case}_{label}_drive.csv"
        with contextlib.redirect_stdout(io.StringIO()):
            assert hyst(["invert", str(model_json), "-o", str(inv_json)]) == 0
            # the compensator on the new trajectory (its input: the desired output)
            assert hyst(["simulate", str(inv_json), "-i", str(yd_csv), "-o", str(drive_csv),
                         "--output-name", "drive"]) == 0
        drive = np.loadtxt(drive_csv, delimiter=",", skiprows=1)[:, -1]
        y_py = plant(drive, dt=dt)
        drive_c = run_c(tmp, model_json, f"{case}_{label}", yd, dt)
        y_c = plant(drive_c, dt=dt)
        out[label] = {"rms_python_um": rms(y_py - yd), "rms_c_um": rms(y_c - yd),
                      "c_vs_python_max_drive_diff": float(np.max(np.abs(drive_c - drive)))}
        traces[label] = y_py
    for k in ("python", "c"):
        out[f"ratio_{k}"] = out["extended"][f"rms_{k}_um"] / out["pi_only"][f"rms_{k}_um"]
    out["traces"] = (t, yd, traces)
    return out


def figure(results: dict):
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    titles = [f"{c}: desired vs achieved (RMS ratio {results[c]['ratio_python']:.2f})"
              for c in results] + [f"{c}: tracking error" for c in results]
    fig = make_subplots(rows=2, cols=2, shared_xaxes="columns", vertical_spacing=0.08,
                        subplot_titles=titles)
    colors = {"extended": "#2ca02c", "pi_only": "#d62728"}
    for j, res in enumerate(results.values(), start=1):
        t, yd, traces = res["traces"]
        fig.add_trace(go.Scatter(x=t, y=yd, name="desired", showlegend=j == 1,
                                 line={"color": "#444", "dash": "dash"}), row=1, col=j)
        for label, y in traces.items():
            name = ("PI + diagnosed effect" if label == "extended" else "PI only")
            fig.add_trace(go.Scatter(x=t, y=y, name=name, line={"color": colors[label]},
                                     showlegend=j == 1), row=1, col=j)
            fig.add_trace(go.Scatter(x=t, y=y - yd, name=name, showlegend=False,
                                     line={"color": colors[label]}), row=2, col=j)
        fig.update_xaxes(title_text="t [s]", row=2, col=j)
    fig.update_yaxes(title_text="y [µm]", row=1, col=1)
    fig.update_yaxes(title_text="y − y_d [µm]", row=2, col=1)
    fig.update_layout(title="Compensators from the same recordings: PI only vs PI + diagnosed "
                      "effect, driving the true plant", height=700, width=1100,
                      template="plotly_white")
    return fig


def main() -> None:
    out = parse_out(__doc__.splitlines()[0])
    rng = np.random.default_rng(0)
    results = {}
    with tempfile.TemporaryDirectory() as tmpdir:
        for case in CASES:
            results[case] = close_the_loop(case, Path(tmpdir), rng)
    for case, res in results.items():
        print(f"{case}: diagnosis found {res['effects_found'] or 'nothing'}; tracking RMS "
              f"PI only {res['pi_only']['rms_python_um']:.4f} um, extended "
              f"{res['extended']['rms_python_um']:.4f} um, ratio {res['ratio_python']:.3f} "
              f"(C: {res['pi_only']['rms_c_um']:.4f} / {res['extended']['rms_c_um']:.4f} um, "
              f"ratio {res['ratio_c']:.3f})")
    save(figure(results), out, "ex14_tracking")
    doc = {c: {k: v for k, v in r.items() if k != "traces"} for c, r in results.items()}
    (out / "ex14_results.json").write_text(json.dumps(doc, indent=2))
    print(f"wrote {out / 'ex14_results.json'}")


if __name__ == "__main__":
    main()
