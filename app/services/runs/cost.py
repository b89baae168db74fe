"""What a fit or a diagnosis of a recording will cost: peak memory and CPU time from
measured per-sample models, and the refusal, in words, of what would not fit in the memory
allowed.

One model for every place that runs them: ``hyst fit`` / ``hyst diagnose``
(:mod:`app.commands._scale`), the batch workers (:mod:`app.batch.single`) and the server's
job workers (:mod:`app.services.jobs.tasks`). The models are lines above the measurements of
``benchmarks/bench_diagnose_scale.py`` (tiled piezo recordings, one thread; the table is in
``docs/pages/diagnose.md``, "Scale"). Re-measure and update them when the memory or the time
of a command changes.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DIAGNOSE", "ETA_FROM_S", "FIT", "WORKER_START_BYTES", "CostModel", "duration_text",
           "memory_refusal", "size_text", "time_left_text"]

#: Runs expected to take at least this long (s) show the time left while they run (the
#: command line's progress lines, the web page's and the 3D / GUI interface's job line).
ETA_FROM_S = 20.0


@dataclass(frozen=True)
class CostModel:
    """Peak memory (bytes) and CPU time (s) of a command as ``base + per_sample * samples``.

    Attributes
    ----------
    base_bytes, bytes_per_sample : float
        Peak resident memory of the whole process, bytes.
    base_cpu_s, cpu_s_per_sample : float
        CPU time on one thread, s.
    verb : str
        What the command does, for messages (``"diagnosing"``).
    """

    base_bytes: float
    bytes_per_sample: float
    base_cpu_s: float
    cpu_s_per_sample: float
    verb: str = "diagnosing"

    def peak_bytes(self, samples: int) -> float:
        """Predicted peak resident memory of ``samples`` samples, bytes."""
        return self.base_bytes + self.bytes_per_sample * samples

    def cpu_s(self, samples: int) -> float:
        """Predicted CPU time of ``samples`` samples on one thread, s."""
        return self.base_cpu_s + self.cpu_s_per_sample * samples

    def most_samples(self, allowed: float) -> int:
        """The most samples whose predicted peak fits in ``allowed`` bytes (in thousands)."""
        return max(0, int((allowed - self.base_bytes) / self.bytes_per_sample) // 1000 * 1000)


#: ``hyst diagnose`` (issue 31; /usr/bin/time, one thread, tilings of the shipped piezo
#: recording, docs/pages/diagnose.md "Scale", round 4: the caches under one byte budget
#: derived from the target 400 MB + 0.3 kB per sample, main eb930e0): peaks of 297, 348,
#: 380, 492, 547, 1,299 and 2,907 MB at 25k, 50k, 100k, 400k, 1M, 4M and 10M samples, all
#: under that target (the closest 28 MB under it, at 400k). 450 MB + 0.3 kB per sample is an
#: upper envelope of every point with at least 78 MB to spare (10M: 3.45 GB predicted, 2.9 GB
#: measured; before the budget the caches filled up to about 550 MB and the model was 900 MB +
#: 0.3 kB). CPU: 3.4, 5.0, 7.1, 21, 13.5, 45 and 132 s (load 4-8).
DIAGNOSE = CostModel(base_bytes=450e6, bytes_per_sample=300.0, base_cpu_s=5.0,
                     cpu_s_per_sample=15e-6)

#: ``hyst fit`` (the same benchmark): peaks of 215, 420, 442, 690 and 1,428 MB at 100k, 1M,
#: 2M, 4M and 10M samples (the reader in blocks), CPU 2.0, 4.7, 5.1, 9.4 and 27 s: an upper
#: envelope of 250 MB + 0.125 kB per sample.
FIT = CostModel(base_bytes=250e6, bytes_per_sample=125.0, base_cpu_s=2.0,
                cpu_s_per_sample=3e-6, verb="fitting")

#: Resident memory of a job worker when it starts (the solvers preloaded): its allowance is
#: counted beyond it, the models above count it in.
WORKER_START_BYTES = 250e6


def size_text(b: float) -> str:
    """Bytes in words: ``"1.2 GB"``, ``"640 MB"``."""
    return f"{b / 1e9:.1f} GB" if b >= 1e9 else f"{b / 1e6:.0f} MB"


def duration_text(s: float) -> str:
    """A duration in words: ``"40 s"``, ``"3 min"``, ``"1.5 h"``."""
    if s < 90:
        return f"{max(1, round(s))} s"
    if s < 5400:
        return f"{round(s / 60)} min"
    return f"{s / 3600:.1f} h"


def time_left_text(expected_s: float, elapsed_s: float, from_s: float = ETA_FROM_S) -> str:
    """What is left of a run expected to take ``expected_s`` after ``elapsed_s`` (both s):
    ``"about 40 s left"``, or ``"taking longer than the 2 min estimated"``; ``""`` for a run
    expected to take less than ``from_s`` (default :data:`ETA_FROM_S`).

    The estimate is the measured CPU-time model (:meth:`CostModel.cpu_s`), not the run's
    progress fraction: a diagnosis's rounds differ in size, so its fraction is not
    proportional to its time.
    """
    if expected_s < from_s:
        return ""
    left = expected_s - elapsed_s
    if left >= 0.5:
        return f"about {duration_text(left)} left"
    return f"taking longer than the {duration_text(expected_s)} estimated"


def memory_refusal(samples: int, model: CostModel, what: str, allowed: float,
                   where: str = "this machine has") -> str | None:
    """The refusal of ``samples`` samples when ``model`` predicts more than ``allowed``
    bytes, in words (what it would need, what there is, what to do), else ``None``.

    Parameters
    ----------
    samples : int
        Samples of the recording(s).
    model : CostModel
        The command's model.
    what : str
        The recording(s) as the user knows them (a file name).
    allowed : float
        Bytes the whole process may take.
    where : str
        Who allows ``allowed`` (``"this machine has"``, ``"a batch worker has"``).
    """
    need = model.peak_bytes(samples)
    if need <= allowed:
        return None
    return (f"{what} holds about {samples:,} samples; {model.verb} it would need about "
            f"{size_text(need)} of memory ({size_text(model.base_bytes)} + "
            f"{model.bytes_per_sample / 1e3:.3g} kB per sample, as measured) and {where} "
            f"{size_text(allowed)} available; use a shorter part of the recording (cut it, or "
            f"decimate it if its sampling rate allows), at most about "
            f"{model.most_samples(allowed):,} samples here")
