"""Heavy figures in a worker process that stops when its client hangs up (issue 18 item 3).

A figure request whose priced work is above :data:`app.services.session.actions.KILLABLE_WORK` is
computed by :func:`run_figures` in a :class:`~app.services.jobs.worker.Worker` process, while the
route polls :meth:`starlette.requests.Request.is_disconnected`: when the client has gone,
the worker is killed (``SIGKILL``: numpy and compiled kernels cannot be interrupted from
inside) and the memory it used goes with it, instead of a core computing for nobody. The
small requests of a slider step never come here.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

from fastapi import HTTPException, Request
from starlette.concurrency import run_in_threadpool

from app.services.errors import ParameterError
from app.services.jobs.worker import LiveWorkers, OutOfMemory, TaskFailed, Worker, WorkerDied
from app.services.session import actions

__all__ = ["run_figures"]

#: Seconds between two looks at the client's connection.
POLL_S = 0.05


def _ignore(fraction: float, message: str = "") -> None:
    pass


async def run_figures(request: Request, run: actions.FiguresRun) -> dict[str, Any]:
    """The JSON body of ``run``: in a worker thread when it is light, else in a worker
    process killed as soon as the client disconnects (then a 499, which nobody reads).

    Raises
    ------
    HTTPException
        499 when the client went away (the work was stopped).
    ParameterError, NotInvertibleError
        The input was refused where the figures were computed, or needed more memory than
        a worker may use (a 422).
    """
    if not run.killable:
        return await run_in_threadpool(actions.figures_here, run)
    live: LiveWorkers = request.app.state.figure_workers
    slots: asyncio.Semaphore = request.app.state.figure_slots
    while True:  # a free slot (at most live.max_running at once), or the client has gone
        try:
            await asyncio.wait_for(slots.acquire(), POLL_S)
            break
        except TimeoutError:
            if await request.is_disconnected():
                raise HTTPException(499, "the client went away before its figures started"
                                    ) from None
    worker = Worker(run.task, live.memory_limit)
    live.add(worker)
    try:
        work = asyncio.ensure_future(run_in_threadpool(worker.run, _ignore))
        while True:
            done, _ = await asyncio.wait({work}, timeout=POLL_S)
            if done:
                break
            if await request.is_disconnected():
                worker.kill()
                with contextlib.suppress(WorkerDied, TaskFailed):
                    await work  # the process is reaped before the slot is given back
                raise HTTPException(499, "the client went away; the figures were stopped")
        try:
            out = work.result()
        except WorkerDied as exc:
            raise HTTPException(503, f"the figures could not be computed: {exc}") from None
        except OutOfMemory as exc:  # the request is too big for this server: a 422
            raise ParameterError(str(exc)) from None
        except TaskFailed as exc:
            raise RuntimeError(f"the figures failed: {exc}") from None
        return actions.figures_body(out)
    finally:
        live.discard(worker)
        slots.release()
