"""One recording of a batch, run on a Dask worker: the single-file command itself.

:func:`run_recording` writes the recording's bytes under its own file name into a private
temporary folder and runs ``hyst fit FILE -o MODEL.json`` or ``hyst diagnose FILE --json
--save-model MODEL.json`` in-process, through the command's own parser and ``run`` function.
The parameter set a batch stores is therefore what the single-file command writes, by
construction, and the worker needs no shared file system: bytes in, documents out.
"""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .options import command_args, command_module

__all__ = ["Outcome", "run_recording"]


@dataclass(frozen=True)
class Outcome:
    """What a worker sends back for one recording.

    Attributes
    ----------
    ok : bool
        The command succeeded.
    error : str
        The command's user-facing error message (empty on success).
    parameter_set : str
        Text of the parameter-set JSON the command wrote (empty on failure).
    diagnosis : str
        For ``diagnose``: the ``--json`` document (one JSON object); else empty.
    samples : int
        Samples in the file (all recordings it holds); 0 when it could not be read.
    messages : str
        Anything the command printed on stderr (warnings, notes).
    elapsed_s : float
        Wall time on the worker (s).
    """

    ok: bool
    error: str = ""
    parameter_set: str = ""
    diagnosis: str = ""
    samples: int = 0
    messages: str = ""
    elapsed_s: float = 0.0


def _samples(kind: str, args: Any, diagnosis: str) -> int:
    """Samples in the recording(s) the command read."""
    if kind == "diagnose":
        return sum(int(r["samples"]) for r in json.loads(diagnosis)["recordings"])
    from core.csvio import read_csv

    from ..commands._common import column_spec

    recs = read_csv(args.files[0], time=column_spec(args.time),
                    input=column_spec(args.input_column), output=column_spec(args.output_column))
    return sum(r.n_samples for r in recs)


def run_recording(kind: str, filename: str, content: bytes, argv: list[str]) -> Outcome:
    """Run the single-file command ``kind`` on one recording.

    Parameters
    ----------
    kind : {"fit", "diagnose"}
        Which command.
    filename : str
        The recording's file name (no folder); the command sees a file of that name, so
        the provenance it writes is the same as for a single-file run.
    content : bytes
        The file's bytes.
    argv : list of str
        The command's options (see :meth:`FitOptions.argv`).

    Returns
    -------
    Outcome
        Never raises for a bad recording: the error is in :attr:`Outcome.error`.
    """
    t0 = time.perf_counter()
    out, err = io.StringIO(), io.StringIO()
    with tempfile.TemporaryDirectory(prefix="hyst-batch-") as tmp:
        src = Path(tmp) / Path(filename).name
        src.write_bytes(content)
        model = Path(tmp) / "model.out.json"
        extra = ["-o", str(model), "-q"] if kind == "fit" else [
            "--json", "--save-model", str(model)]
        try:
            args = command_args(kind, [str(src), *argv, *extra])
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                command_module(kind).run(args)
            diagnosis = out.getvalue().strip() if kind == "diagnose" else ""  # one JSON object
            return Outcome(True, parameter_set=model.read_text(encoding="utf-8"),
                           diagnosis=diagnosis, samples=_samples(kind, args, diagnosis),
                           messages=err.getvalue(), elapsed_s=time.perf_counter() - t0)
        except (ValueError, OSError) as exc:  # what `hyst` reports as "error: ..."
            msg = str(exc).replace(str(src), filename).replace(tmp + "/", "")
            return Outcome(False, error=msg, messages=err.getvalue(),
                           elapsed_s=time.perf_counter() - t0)
        except Exception as exc:  # noqa: BLE001 - one bad recording never stops the batch
            return Outcome(False, error=f"internal error ({type(exc).__name__}): {exc}",
                           messages=err.getvalue(), elapsed_s=time.perf_counter() - t0)
