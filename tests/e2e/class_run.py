"""A class in real Chromium: one teacher's web page leads a shipped lesson to web and viser
students, and every page records, in the browser, when it shows each step.

Used by the short browser test (``test_class_of_students.py``: correctness only) and by
``benchmarks/bench_class.py`` (a class of thirty, arrival times). The teacher clicks on
its own page (Start, Next, the push of an edited model); the click's time is taken in that
page (``Date.now()``, the machine's clock, as every student page's records are).

What a student "shows" (the step arrived):

- a web page: the step's texts and sliders are on show (``body[data-step-shown]``, lesson.js's
  count of the steps shown, changed after the click and ``body[data-lesson-step]`` is the
  step: the page is on it); for the push, the note also says the class step changed. The
  step's figure comes after: *drawn* when ``body[data-fig]`` is its view, drawn after the
  click (``body[data-ready]``, the session version of the drawn figure, changed);
- a viser tab: its *Lesson* folder says "step k of n" and "You are on the class step." (for
  the push: the tab's note says the teacher changed the class step).

Every page also records whether it was ever told "You are exploring" (the web page's
``#lesson-state``, the viser folder's text) while the lesson ran; no student here moves.
"""

from __future__ import annotations

import json
import statistics
import time
import urllib.request
from dataclasses import dataclass, field
from typing import Any

from .conftest import TEACHER_TOKEN
from .test_classroom import _viser_session_folder, _viser_type
from .test_viser_gui import _open as _open_viser
from .test_web_journeys import _listening, _open, _text_has

#: Records every change of what a web page shows (at the task after the frame that paints
#: it): [time ms, step, view, drawn version,
#: lesson state text, live note text, steps shown (lesson.js's count)].
WEB_RECORDER = """() => {
  window.__rec = [];
  performance.setResourceTimingBufferSize(10000);  // the figure requests' timings
  const b = document.body;
  const txt = (id) => { const e = document.getElementById(id); return e ? e.textContent : ""; };
  const rec = () => {
    const r = [Date.now(), b.dataset.lessonStep || "", b.dataset.fig || "", b.dataset.ready || "",
               txt("lesson-state"), txt("live-note"), b.dataset.stepShown || ""];
    const last = window.__rec[window.__rec.length - 1];
    if (!last || r.slice(1).some((v, i) => v !== last[i + 1])) window.__rec.push(r);
  };
  // a change is recorded once it is painted: at the task after the next frame's rendering
  let pending = false;
  const painted = () => { if (!pending) { pending = true;
    requestAnimationFrame(() => setTimeout(() => { pending = false; rec(); }, 0)); } };
  new MutationObserver(painted).observe(b, { attributes: true,
    attributeFilter: ["data-lesson-step", "data-fig", "data-ready", "data-step-shown"] });
  for (const id of ["lesson-state", "live-note"]) {
    new MutationObserver(painted).observe(document.getElementById(id),
      { childList: true, characterData: true, subtree: true });
  }
  rec();
}"""

#: Records every change of a viser tab's *Lesson* folder and plot, looked at after the
#: frame that paints a change of the page (the folder's elements are re-made by React):
#: [time ms, step, on the class step, exploring, the teacher's note says the class step
#: changed, figures drawn (each new plotly data of the tab's plots)].
VISER_RECORDER = """() => {
  window.__rec = [];
  let box = null;
  let drawn = 0;
  const seen = new WeakSet();
  const find = () => [...document.querySelectorAll(".mantine-Paper-root")]
    .filter((e) => /^Lesson/.test(e.textContent)
      && e.textContent.includes("Back to the class step"))
    .pop() || null;
  const tick = () => {
    if (!box || !box.isConnected) box = find();
    if (!box) return;
    const t = box.textContent;
    const m = /step (\\d+) of (\\d+)/.exec(t);
    const edit = Boolean(window.__watchPush)
      && document.body.textContent.includes("changed the class step");
    for (const gd of document.querySelectorAll(".js-plotly-plot")) {
      if (gd.data && !seen.has(gd.data)) { seen.add(gd.data); drawn += 1; }
    }
    const r = [Date.now(), m ? m[1] : "", t.includes("You are on the class step"),
               t.includes("You are exploring"), edit, drawn];
    const last = window.__rec[window.__rec.length - 1];
    if (!last || r.slice(1).some((v, i) => v !== last[i + 1])) window.__rec.push(r);
  };
  // a change of the page is looked at once it is painted: in the task after the next
  // frame's rendering (a React commit followed by a long task is painted after that task)
  let pending = false;
  new MutationObserver(() => { if (!pending) { pending = true;
    requestAnimationFrame(() => setTimeout(() => { pending = false; tick(); }, 0)); } })
    .observe(document.body, { childList: true, characterData: true, subtree: true });
  setInterval(tick, 500);
  tick();
}"""

#: Run in a viser tab before viser's own scripts: every batch of messages the tab's
#: websocket worker hands to the page is recorded when it reaches the page's main thread,
#: [time ms, messages, the lesson step it says the tab is on ("" if none), characters of
#: plotly figures in it, scene (non-GUI) messages in it, ms the page's handler took], and
#: the page's long tasks ([start ms, duration ms]): where a viser student's time goes.
VISER_WIRE = """(() => {
  window.__wire = [];
  window.__long = [];
  try {
    new PerformanceObserver((l) => { for (const e of l.getEntries()) {
      window.__long.push([performance.timeOrigin + e.startTime, e.duration]); } })
      .observe({ type: "longtask", buffered: true });
  } catch (e) { /* no long task timing */ }
  const d = Object.getOwnPropertyDescriptor(Worker.prototype, "onmessage");
  Object.defineProperty(Worker.prototype, "onmessage", {
    configurable: true,
    get() { return d.get.call(this); },
    set(fn) {
      d.set.call(this, function (ev) {
        const x = ev.data;
        if (!x || x.type !== "message_batch") return fn.call(this, ev);
        const t = Date.now();
        let step = "", plot = 0, scene = 0;
        for (const m of x.messages) {
          for (const v of Object.values(m.updates || {})) {
            if (typeof v !== "string") continue;
            const r = /step (\\d+) of \\d+/.exec(v);
            if (r && v.includes("You are on the class step")) step = r[1];
          }
          const js = (m.updates || {})._plotly_json_str;
          if (typeof js === "string") plot += js.length;
          if (!/^(Gui|Notification|RemoveNotification|SetGuiPanel)/.test(m.type)) scene += 1;
        }
        const row = [t, x.messages.length, step, plot, scene, 0];
        window.__wire.push(row);
        const out = fn.call(this, ev);
        row[5] = Date.now() - t;
        return out;
      });
    },
  });
})()"""

#: The teacher's page: the time of each click on a lesson button or the push.
CLICK_RECORDER = """() => {
  window.__clicks = [];
  document.addEventListener("click", (e) => {
    const b = e.target.closest("button");
    if (b && b.id) window.__clicks.push([Date.now(), b.id]);
  }, true);
}"""


@dataclass
class Student:
    """One student's page: ``kind`` "web" or "viser", its name and playwright objects."""

    kind: str
    name: str
    ctx: Any
    page: Any
    view: Any = None  # a viser tab's SessionView (server side)
    phone: bool = False
    #: a viser tab's Lesson folder as the server set it: (time ms, text)
    server_said: list[tuple[float, str]] = field(default_factory=list)
    #: a viser tab's renders in the server (its plot, texts and scene): (start, end) ms
    renders: list[tuple[float, float]] = field(default_factory=list)


@dataclass
class Move:
    """One click of the teacher: which step it shows (``edit``: the push) and when."""

    label: str
    step: int
    view: str
    edit: bool
    t0: float = 0.0  # ms, the teacher page's clock
    teacher_says: str = ""  # the teacher's message after the click
    teacher_step: str = ""  # the teacher page's data-lesson-step once the class is there
    teacher_note: str = ""  # the teacher page's live note then
    arrivals: dict[str, float | None] = field(default_factory=dict)  # name -> ms after t0
    #: web: when the page had drawn the step's figure (ms after t0; the arrival is the step
    #: shown, its texts and sliders, before it)
    drawn: dict[str, float | None] = field(default_factory=dict)
    #: web: when the page asked for the step's figure, and when it had it (ms after t0);
    #: viser: when the server set the tab's Lesson folder to the step (ms after t0)
    asked: dict[str, float | None] = field(default_factory=dict)
    received: dict[str, float | None] = field(default_factory=dict)
    #: viser: when the message batch saying the step reached the tab's main thread (ms
    #: after t0); the server's render of the move in the tab (its end, ms after t0, and
    #: its duration, ms); the tab's main thread busy in long tasks from t0 to the arrival
    #: (ms); plotly characters and scene messages the tab was sent from t0 to the arrival
    wire: dict[str, float | None] = field(default_factory=dict)
    plot: dict[str, float | None] = field(default_factory=dict)  # viser: its plot drawn
    rendered: dict[str, float | None] = field(default_factory=dict)
    render_ms: dict[str, float | None] = field(default_factory=dict)
    busy: dict[str, float | None] = field(default_factory=dict)
    plot_chars: dict[str, int] = field(default_factory=dict)
    scene_msgs: dict[str, int] = field(default_factory=dict)
    #: the server's figure computations from the click to the end of the wait (the
    #: ``computations`` count given to :func:`run_lesson`; ``None`` without one)
    computed: int | None = None


@dataclass
class ClassRun:
    """What a run of the class recorded."""

    moves: list[Move]
    told_exploring: list[str]  # students told "You are exploring" (none moved)
    expected_counts: str
    connected: list[dict[str, int]]
    students: list[Student]

    def arrivals(self, kind: str | None = None, what: str = "arrivals") -> list[float]:
        """Every student's times of every click (``what``: ``arrivals``, ``drawn``,
        ``asked`` or ``received``), of the students of ``kind`` ("web", "viser"; ``None``:
        all)."""
        kinds = {s.name: s.kind for s in self.students}
        return [a for m in self.moves for n, a in getattr(m, what).items()
                if a is not None and (kind is None or kinds[n] == kind)]

    def missing(self) -> list[tuple[str, str]]:
        """(move, student) pairs where the student never showed the step (a web page: or
        never drew its figure)."""
        return [(m.label, n) for m in self.moves for n, a in m.arrivals.items()
                if a is None or (n in m.drawn and m.drawn[n] is None)]


def percentile(xs: list[float], q: float) -> float:
    """The ``q`` quantile (0..1) of ``xs`` (linear between order statistics)."""
    if not xs:
        return float("nan")
    s = sorted(xs)
    k = (len(s) - 1) * q
    lo, hi = int(k), min(int(k) + 1, len(s) - 1)
    return s[lo] + (s[hi] - s[lo]) * (k - lo)


def median(xs: list[float]) -> float:
    return statistics.median(xs) if xs else float("nan")


def connected(url: str) -> dict[str, int]:
    """The teacher's ``GET /api/teacher/connected`` (counts only)."""
    req = urllib.request.Request(url + "api/teacher/connected",
                                 headers={"X-Teacher-Token": TEACHER_TOKEN})
    with urllib.request.urlopen(req, timeout=10) as r:
        c = json.load(r)
    return {k: c[k] for k in ("pages", "viser_tabs", "sessions_live")}


def counts_text(web_pages: int, viser_tabs: int) -> str:
    """What the teacher should read: every page and tab open, each its own session."""
    s = lambda n, w: f"{n} {w}" + ("" if n == 1 else "s")  # noqa: E731
    return (f"{s(web_pages, 'web page')} and {s(viser_tabs, '3D / GUI tab')} open, in "
            f"{s(web_pages + viser_tabs, 'session')}")


def open_class(browser: Any, url: str, viser_url: str, app: Any, n_web: int, n_viser: int,
               *, phone: bool = True) -> tuple[Any, list[Student]]:
    """The teacher's web page (1400x1000) and the students, named "Web 01", "Tab 01", ...
    (the first web student on a 390x844 phone when ``phone``); each listening and
    recording. Returns ``(teacher page, students)``; close them with :func:`close_class`."""
    students: list[Student] = []
    for k in range(n_web):
        on_phone = phone and k == 0
        ctx, page, _ = _open(browser, url, *((390, 844) if on_phone else (1000, 760)))
        name = f"Web {k + 1:02d}"
        page.fill("#my-name", name)
        page.press("#my-name", "Enter")
        students.append(Student("web", name, ctx, page, phone=on_phone))
    known = set(app.state.gui.views)
    for k in range(n_viser):
        ctx, page, _ = _open_viser(browser, viser_url, 1200, 800, init=VISER_WIRE)
        view = _new_view(app, known)
        known.add(next(key for key, v in app.state.gui.views.items() if v is view))
        name = f"Tab {k + 1:02d}"
        _viser_session_folder(page)
        _viser_type(page, "Your name", name)
        students.append(Student("viser", name, ctx, page, view))
        _watch_panel(students[-1])
        _watch_renders(students[-1])
    ctx_t, t, _ = _open(browser, url, 1400, 1000)
    t.evaluate(CLICK_RECORDER)
    web = [s.page for s in students if s.kind == "web"]
    _listening(url, t, *web)
    _wait(lambda: connected(url)["viser_tabs"] >= n_viser, "the viser tabs are not counted")
    for s in students:
        s.page.evaluate(WEB_RECORDER if s.kind == "web" else VISER_RECORDER)
    t.evaluate(WEB_RECORDER)
    return (ctx_t, t), students


def _watch_panel(s: Student) -> None:
    """Keep every text the server gives the tab's Lesson folder, with its time (the
    folder's ``_show`` wrapped on this tab's panel only)."""
    panel = s.view.lesson
    show = panel._show

    def _show(*args: Any, **kw: Any) -> None:
        show(*args, **kw)
        s.server_said.append((time.time() * 1e3, str(panel.md.content)))

    panel._show = _show


def _watch_renders(s: Student) -> None:
    """Keep the start and end of every render of the tab in the server."""
    worker = s.view.worker
    render = worker._render

    def timed() -> None:
        t0 = time.time() * 1e3
        try:
            render()
        finally:
            s.renders.append((t0, time.time() * 1e3))

    worker._render = timed


def _viser_where(s: Student, m: Move) -> None:
    """Where a viser tab's time of ``m`` went (the :class:`Move` fields ``wire`` ...)."""
    wire, long = s.page.evaluate("() => [window.__wire || [], window.__long || []]")
    arrived = m.arrivals.get(s.name)
    end = m.t0 + (arrived if arrived is not None else 60_000.0)
    got = next((w for w in wire if w[0] >= m.t0 and w[2] == str(m.step)), None)
    m.wire[s.name] = None if got is None else got[0] - m.t0
    mine = [w for w in wire if m.t0 <= w[0] <= end]
    m.plot_chars[s.name] = sum(w[3] for w in mine)
    m.scene_msgs[s.name] = sum(w[4] for w in mine)
    m.busy[s.name] = sum(max(0.0, min(a + d, end) - max(a, m.t0)) for a, d in long)
    r = next((r for r in s.renders if r[0] >= m.t0 - 50), None)
    m.rendered[s.name] = None if r is None else r[1] - m.t0
    m.render_ms[s.name] = None if r is None else r[1] - r[0]


def _figure_requests(page: Any) -> list[list[float]]:
    """[start, end] (ms, the machine's clock) of every figure request of the page."""
    return page.evaluate("""() => performance.getEntriesByType("resource")
      .filter((e) => e.name.includes("/figures?"))
      .map((e) => [performance.timeOrigin + e.startTime,
                   performance.timeOrigin + e.responseEnd])""")


def _new_view(app: Any, known: set[Any], timeout: float = 60.0) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        new = [v for k, v in app.state.gui.views.items() if k not in known]
        if new and new[0].rendered_version >= 0:
            return new[0]
        time.sleep(0.1)
    raise AssertionError("no new viser tab")


def _wait(cond: Any, what: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(what)
        time.sleep(0.1)


def close_class(teacher: tuple[Any, Any], students: list[Student]) -> None:
    for ctx in [teacher[0], *(s.ctx for s in students)]:
        try:
            ctx.close()
        except Exception:  # noqa: BLE001 - already closed
            pass


def _arrival(s: Student, rec: list[list[Any]], m: Move, before: tuple[str, str],
             drawn: bool = False) -> float | None:
    """When ``s`` showed ``m``'s step (``drawn``: a web page had drawn its figure);
    ``before``: the page's drawn version and steps-shown count before the click."""
    for r in rec:
        if r[0] < m.t0:
            continue
        if s.kind == "web":
            _, step, fig, ready, _, note, shown = r[:7]
            ok = step == str(m.step) and (
                (fig == m.view and ready != before[0]) if drawn else shown != before[1])
            if m.edit:
                ok = ok and "changed the class step" in note
        else:
            _, step, on, _, edit, figs = r
            ok = step == str(m.step) and on and (edit or not m.edit)
            if drawn:
                ok = ok and figs > int(before[0] or 0)
        if ok:
            return float(r[0] - m.t0)
    return None


def _records(page: Any) -> list[list[Any]]:
    return page.evaluate("() => window.__rec")


def _shows(s: Student, m: Move, before: tuple[str, str]) -> bool:
    rec = _records(s.page)
    return _arrival(s, rec, m, before) is not None and (
        s.kind != "web" or _arrival(s, rec, m, before, drawn=True) is not None)


def run_lesson(url: str, teacher: tuple[Any, Any], students: list[Student], *,
               lesson: str = "pi-basics", push_at: int = 2, settle_s: float = 1.0,
               timeout_s: float = 60.0, after_push: Any = None,
               computations: Any = None, at_last: Any = None) -> ClassRun:
    """The teacher starts ``lesson``, moves the class through every step and, at step
    ``push_at``, edits p0 on its page and pushes the model; after each click every student
    is waited for (``timeout_s``), then ``settle_s`` more (a late wrong note is seen).
    ``after_push()`` is called once the class has the push, ``at_last()`` once it has the
    last step (screenshots);
    ``computations()``, when given, is the server's count of figure computations so far
    (each move's share kept in :attr:`Move.computed`)."""
    from app.services.teaching.lessons import builtin_lesson

    t = teacher[1]
    steps = builtin_lesson(lesson).steps
    n_web = sum(s.kind == "web" for s in students) + 1  # and the teacher's page
    expected = counts_text(n_web, len(students) - n_web + 1)
    t.click("#teacher summary")
    t.fill("#teacher-token", TEACHER_TOKEN)
    t.select_option("#lesson-pick", f"name:{lesson}")
    moves: list[Move] = []
    conn: list[dict[str, int]] = []

    def click(button: str, m: Move, msg: str) -> None:
        before = {s.name: _before(s) for s in students}
        clicks0 = len(t.evaluate("() => window.__clicks"))
        computed0 = computations() if computations is not None else 0
        if m.edit:
            for s in students:
                if s.kind == "viser":
                    s.page.evaluate("() => { window.__watchPush = true; }")
        t.click(button)
        _text_has(t, msg, "to the class" if m.edit else f"Step {m.step} of {len(steps)}")
        m.t0 = float(t.evaluate("() => window.__clicks")[clicks0][0])
        m.teacher_says = t.inner_text(f"#{msg}")
        deadline = time.monotonic() + timeout_s
        waiting = list(students)
        while waiting and time.monotonic() < deadline:
            waiting = [s for s in waiting if not _shows(s, m, before[s.name])]
            time.sleep(0.1)
        conn.append(connected(url))
        time.sleep(settle_s)
        m.teacher_step = t.evaluate("() => document.body.dataset.lessonStep")
        m.teacher_note = t.inner_text("#live-note")
        if computations is not None:
            m.computed = computations() - computed0
        for s in students:
            rec = _records(s.page)
            m.arrivals[s.name] = _arrival(s, rec, m, before[s.name])
            if s.kind == "web":
                m.drawn[s.name] = _arrival(s, rec, m, before[s.name], drawn=True)
                req = next((r for r in _figure_requests(s.page) if r[0] >= m.t0), None)
                m.asked[s.name] = None if req is None else req[0] - m.t0
                m.received[s.name] = None if req is None else req[1] - m.t0
            else:
                said = next((t for t, text in s.server_said if t >= m.t0
                             and f"step {m.step} of" in text and "on the class step" in text),
                            None)
                m.received[s.name] = None if said is None else said - m.t0
                # a new figure in the tab's plot (none when it is the one shown: step 1)
                m.plot[s.name] = _arrival(s, rec, m, before[s.name], drawn=True)
                _viser_where(s, m)
        moves.append(m)

    click("#lesson-start", Move("step 1", 1, steps[0].view, False), "lesson-msg")
    for k in range(2, len(steps) + 1):
        click("#lesson-next", Move(f"step {k}", k, steps[k - 1].view, False), "lesson-msg")
        if k == push_at:
            t.locator("#ctl-p0").focus()
            for _ in range(3):
                t.locator("#ctl-p0").press("ArrowRight")
            t.wait_for_function("() => document.body.dataset.lessonStep === 'exploring'")
            t.wait_for_timeout(500)  # the edit stored before it is pushed
            click("#teacher-push-mine", Move(f"push at step {k}", k, steps[k - 1].view, True),
                  "teacher-msg")
            if after_push is not None:
                after_push()
    if at_last is not None:
        at_last()
    told = [s.name for s in students if _told_exploring(s, _records(s.page))]
    t.click("#lesson-end")
    _text_has(t, "lesson-msg", "Lesson ended")
    return ClassRun(moves, told, expected, conn, students)


def _before(s: Student) -> tuple[str, str]:
    """A web page's drawn version and steps-shown count now (a viser tab: the figures it
    has drawn)."""
    if s.kind != "web":  # the figures it has drawn
        return (str((_records(s.page) or [[0, "", "", "", "", 0]])[-1][5]), "")
    last = (_records(s.page) or [[0, "", "", "", "", "", ""]])[-1]
    return (last[3], last[6])


def _told_exploring(s: Student, rec: list[list[Any]]) -> bool:
    if s.kind == "web":
        return any(r[1] == "exploring" or "exploring" in r[4] for r in rec)
    return any(r[3] for r in rec)
