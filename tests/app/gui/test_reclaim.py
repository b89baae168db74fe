"""The GUI's memory reclaimer (app/gui/reclaim.py): one pass per burst of closing tabs, and a
pass also while tabs keep opening and closing (a debounce alone would postpone it forever)."""

from __future__ import annotations

import gc
import time

from app.gui.reclaim import Reclaimer, release_free_memory


def test_a_burst_gives_one_pass_after_it_is_quiet() -> None:
    r = Reclaimer(quiet_s=0.2, max_wait_s=30.0, release=lambda: None)
    try:
        for _ in range(10):
            r.request()
            time.sleep(0.01)
        assert r.passes == 0  # not while the burst goes on
        deadline = time.monotonic() + 10
        while r.passes == 0 and time.monotonic() < deadline:
            time.sleep(0.02)
        time.sleep(0.5)
        assert r.passes == 1
    finally:
        r.stop()


def test_endless_churn_still_gets_passes() -> None:
    r = Reclaimer(quiet_s=0.2, max_wait_s=0.4, release=lambda: None)
    try:
        end = time.monotonic() + 2.0
        while time.monotonic() < end:  # never quiet for 0.2 s
            r.request()
            time.sleep(0.05)
        assert r.passes >= 2
    finally:
        r.stop()


def test_a_pass_frees_cyclic_garbage() -> None:
    class Node:
        pass

    gc.disable()  # no automatic collection in between
    try:
        a, b = Node(), Node()
        a.other, b.other = b, a  # a cycle only the cyclic collector frees
        del a, b
        assert any(type(o) is Node for o in gc.get_objects())
        release_free_memory()
        assert not any(type(o) is Node for o in gc.get_objects())
    finally:
        gc.enable()
