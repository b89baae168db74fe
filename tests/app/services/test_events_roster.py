"""The teacher's list of who is connected: counts and names, never session codes."""

from __future__ import annotations

import asyncio
import threading

from app.services.events import NAME_MAX, EventHub, person_name


def test_names_are_cleaned_and_bounded() -> None:
    assert person_name("  Ana\n\t<b>Lee</b>\x00 ") == "Ana <b>Lee</b>"
    assert len(person_name("x" * 500)) == NAME_MAX
    assert person_name(None) == ""


def test_roster_counts_pages_and_tabs_and_names_without_codes() -> None:
    hub = EventHub()
    assert hub.roster().text.startswith("Nobody is connected")

    async def scenario() -> str:
        a = hub.subscribe("code-aaaa", name="Ana")
        hub.subscribe("code-bbbb")  # no name
        hub.attend("tab-1", "code-cccc", "ben")
        hub.attend("tab-2", "code-aaaa", "Ana")  # the same student in viser too
        r = hub.roster()
        assert (r.web_pages, r.viser_tabs, r.sessions_live) == (2, 2, 3)
        assert r.names == ("Ana", "ben") and r.unnamed == 1
        hub.unsubscribe(a)
        hub.leave("tab-2")
        assert hub.roster().names == ("ben",)
        return r.text

    # in a thread of its own: a browser test's event loop may be running in this one
    out: list[str] = []
    th = threading.Thread(target=lambda: out.append(asyncio.run(scenario())))
    th.start()
    th.join(30)
    (text,) = out
    assert text == ("2 web pages and 2 3D / GUI tabs open, in 3 sessions. "
                    "Names: Ana, ben, and 1 without a name.")
    assert "code-" not in text


def test_broadcast_tells_the_listeners_and_counts_them() -> None:
    hub = EventHub()
    got: list[dict] = []
    hub.add_listener(lambda ev: got.append(ev) or 2)
    assert hub.broadcast({"kind": "push", "title": "x"}) == 2
    assert got[0]["title"] == "x" and got[0]["id"] == 1
