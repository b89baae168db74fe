"""``hyst`` runs the numeric libraries on one thread unless ``--threads N`` asks (issue 31).

A fresh interpreter without the thread variables of the test environment (so OpenBLAS starts
with one thread per CPU, as on a user's machine) runs ``hyst fit`` and ``hyst diagnose``
through :func:`app.cli.main`, with the fitting / diagnosis call replaced by a probe that reads
threadpoolctl's report of every loaded BLAS pool from inside the command; the report after
the command shows the process's own setting is back.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from core.threads import max_threads

ROOT = Path(__file__).resolve().parents[2]
PIEZO = ROOT / "examples" / "data" / "piezo" / "piezo_150V_1Hz.csv"

PROBE = r"""
import json, sys
import numpy, scipy.linalg
from threadpoolctl import threadpool_info
import app.services.analysis.diagnosis as diagnosis
import core.fitting
from core.exceptions import ParameterError

def blas():
    return sorted({p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"})

seen = []
def probe(*args, **kwargs):
    seen.append(blas())
    raise ParameterError("probe: stop here")

core.fitting.fit_recordings = probe
diagnosis.diagnose_files = probe
from app.cli import main

out = {"before": blas()}
for label, argv in json.loads(sys.argv[1]):
    rc = main(argv)
    out[label] = {"rc": rc, "inside": seen.pop(), "after": blas()}
print(json.dumps(out))
"""


@pytest.mark.skipif(max_threads() < 2, reason="needs two CPUs to tell 1 from 2")
def test_hyst_commands_run_on_one_thread_unless_asked(tmp_path):
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    env["PYTHONPATH"] = str(ROOT)
    out = str(tmp_path / "m.json")
    runs = [("fit", ["fit", str(PIEZO), "-o", out]),
            ("fit 2", ["fit", str(PIEZO), "-o", out, "--threads", "2"]),
            ("diagnose", ["diagnose", str(PIEZO), "-q", "--json"]),
            ("diagnose 2", ["diagnose", str(PIEZO), "-q", "--json", "--threads", "2"])]
    proc = subprocess.run([sys.executable, "-c", PROBE, json.dumps(runs)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    top = max_threads()
    assert got["before"] == [top]  # OpenBLAS's own default: one thread per CPU
    assert got["fit"] == {"rc": 2, "inside": [1], "after": [top]}
    assert got["fit 2"] == {"rc": 2, "inside": [2], "after": [top]}
    assert got["diagnose"] == {"rc": 2, "inside": [1], "after": [top]}
    assert got["diagnose 2"] == {"rc": 2, "inside": [2], "after": [top]}
    assert "probe: stop here" in proc.stderr  # the probe ran inside each command


def test_threads_option_refuses_what_is_not_a_thread_count(capsys):
    from app.cli import main

    for bad, why in (("0", "between 1 and"), ("-2", "between 1 and"), ("two", "whole number"),
                     ("1.5", "whole number"), (str(max_threads() + 1), "between 1 and")):
        with pytest.raises(SystemExit) as exc:
            main(["fit", str(PIEZO), "-o", "never.json", "--threads", bad])
        assert exc.value.code == 2
        assert why in capsys.readouterr().err
