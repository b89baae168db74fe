"""Join on a phone (issue 33, item 4), in real Chromium at 390x844, device-pixel ratio 3:
Join says what it did where the phone shows it (under the header, on the first screen), a
wrong code's message too (it was 1.5 screens down, under the plot)."""

from __future__ import annotations

from typing import Any

ON_SCREEN = """(id) => { window.scrollTo(0, 0);
  const r = document.getElementById(id).getBoundingClientRect();
  return r.height > 0 && r.top >= 0 && r.bottom <= window.innerHeight; }"""


def test_join_on_a_phone_answers_on_the_first_screen(browser: Any, live_server: dict,
                                                     shot: Any) -> None:
    url = live_server["url"]
    other = browser.new_context(viewport={"width": 1200, "height": 800})
    ctx = browser.new_context(viewport={"width": 390, "height": 844}, device_scale_factor=3,
                              is_mobile=True, has_touch=True)
    try:
        p0 = other.new_page()
        p0.goto(url)
        p0.wait_for_selector("body[data-ready]")
        code = p0.inner_text("#code")
        page = ctx.new_page()
        page.set_default_timeout(60_000)
        page.goto(url)
        page.wait_for_selector("body[data-ready]")
        mine = page.inner_text("#code")
        page.fill("#join-code", "abcd-efgh-jkmn-pqrs")
        page.click("#join")
        page.wait_for_function("() => document.getElementById('live-note').textContent"
                               ".includes('No session')")
        assert page.evaluate(ON_SCREEN, "live-note"), "the wrong code's message is off screen"
        assert mine in page.inner_text("#live-note")  # still in its own session
        shot(page, "phone-join-wrong-code")
        page.fill("#join-code", code)
        page.click("#join")
        page.wait_for_function("c => document.getElementById('live-note').textContent"
                               " === `Joined session ${c}.`", arg=code)
        assert page.evaluate(ON_SCREEN, "live-note")
        assert page.inner_text("#code") == code
        shot(page, "phone-join-joined")
    finally:
        ctx.close()
        other.close()
