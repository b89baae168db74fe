"""The teacher's list of who is connected: counts and names, never session codes."""

from __future__ import annotations

import asyncio
import threading

from app.services.teaching.events import NAME_MAX, EventHub, person_name


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


def test_a_page_between_two_streams_is_still_counted() -> None:
    """A stream that ended at its time limit (the page reconnects in about 0.5 s) keeps its
    page in the roster for RETURN_S; its return is counted once; a closed page is not."""
    hub = EventHub()

    async def scenario() -> list[tuple[int, int]]:
        a = hub.subscribe("code-aaaa", client="1.2.3.4", name="Ana")
        b = hub.subscribe("code-bbbb", client="1.2.3.4")
        counts = [(hub.roster().web_pages, hub.roster().sessions_live)]
        hub.unsubscribe(a, returning=True)  # between two streams
        hub.unsubscribe(b)  # closed
        r = hub.roster()
        counts.append((r.web_pages, r.sessions_live))
        assert r.names == ("Ana",)
        hub.subscribe("code-aaaa", client="1.2.3.4", name="Ana")  # back: counted once
        counts.append((hub.roster().web_pages, hub.roster().sessions_live))
        return counts

    out: list[list[tuple[int, int]]] = []
    th = threading.Thread(target=lambda: out.append(asyncio.run(scenario())))
    th.start()
    th.join(30)
    assert out == [[(2, 2), (1, 1), (1, 1)]]


def test_the_push_message_counts_the_class() -> None:
    hub = EventHub()
    hub.attend("tab-1", "code-cccc", "ben")
    assert hub.roster().sent_text("Step 2 of 6 sent") == (
        "Step 2 of 6 sent to the class: 0 web pages and 1 3D / GUI tab open, in 1 session.")
    hub.leave("tab-1")
    assert "no page or tab is open" in hub.roster().sent_text("Pushed a model")
