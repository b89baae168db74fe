"""A session whose diagnosis an older version stored (issue 34): the diagnosis is dropped
when the session is opened (tests/app/services/storage/test_store_parts.py builds that
session from the old store format), and the page's Diagnosis view says why under the plot
in the server's words, instead of the placeholder a session never diagnosed shows."""

from __future__ import annotations

from typing import Any

from app.services.storage.store_parts import OLD_DIAGNOSIS_NOTE

from .test_web_journeys import _clean, _open


def _diagnosis_view(page: Any) -> str:
    page.click('#tabs button[data-fig="diagnosis"]')
    page.wait_for_function("() => document.body.dataset.fig === 'diagnosis'")
    return page.inner_text("#notes")


def test_the_diagnosis_view_says_why_an_old_diagnosis_is_gone(browser: Any,
                                                              live_server: dict,
                                                              shot: Any) -> None:
    app = live_server["app"]
    ctx, page, log = _open(browser, live_server["url"])
    try:
        # never diagnosed: the placeholder, no note
        assert "older version" not in _diagnosis_view(page)
        session = app.state.registry.get(page.inner_text("#code"))
        # the state a session stored before 2026-12-05 is opened in (the load path itself:
        # test_store_parts); notify draws the page again
        session._commit({"diagnosis_note": OLD_DIAGNOSIS_NOTE}, recording=False,
                        results=True)
        page.click('#tabs button[data-fig="loop"]')
        page.wait_for_function("() => document.body.dataset.fig === 'loop'")
        notes = _diagnosis_view(page)
        shot(page, "old-diagnosis-note")
        assert "stored by an older version" in notes and "run the diagnosis again" in notes
        title = page.evaluate("() => document.getElementById('figure')._fullLayout.title.text")
        assert title.startswith("The stored diagnosis was dropped")
        assert notes.lstrip("⚠ ").startswith("This session's diagnosis")
        _clean(page, log)
    finally:
        ctx.close()
