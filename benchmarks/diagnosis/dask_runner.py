"""Where ``run_benchmark.py`` runs its scenarios: a local process pool (default) or Dask.

:func:`executor` returns a :class:`concurrent.futures.Executor` in every case, so the
benchmark's ``submit`` / ``as_completed`` loop is the same code on one machine and on a
cluster (``distributed.Client.get_executor`` gives standard ``concurrent.futures`` futures).
Workers started by hand must import this repository (run ``dask worker`` with
``PYTHONPATH`` set to the repository root).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor

__all__ = ["executor"]


@contextlib.contextmanager
def executor(workers: int, scheduler: str | None = None) -> Iterator[Executor]:
    """A process pool of ``workers`` (no ``scheduler``), a Dask LocalCluster of ``workers``
    single-thread processes (``scheduler="local"``), or the Dask cluster at
    ``scheduler="tcp://HOST:PORT"``."""
    if scheduler is None:
        with ProcessPoolExecutor(max_workers=workers) as ex:
            yield ex
        return
    from app.batch.runner import connect

    with connect(None if scheduler == "local" else scheduler, workers) as client:
        print(f"Dask: {len(client.nthreads())} workers at {client.scheduler.address}",
              flush=True)
        yield client.get_executor(pure=False)
