// The figure on show: the view tabs, their help, and drawing the session's figure (or a
// fit's / diagnosis's result) with its status line.

import { api, plain } from "/client.js";
import { showDigiControls } from "/digitized.js";
import { $, setMsg } from "/dom.js";
import { render, SETTLE_MS } from "/plots.js";
import { state } from "/store.js";

export const VIEW_HELP = {
  loop: "Output against input: the area inside the loop is the hysteresis. Dashed: the initial loading curve.",
  time: "Input u(t) on top, the model's output y(t) below (and the measurement when a recording is used).",
  operators: "Each play operator's share of the output, stacked; together with p0·u they add up to y.",
  loading: "The initial loading curve φ(r) and its slopes: all slopes > 0 means the model can be inverted.",
  inverse: "Left: the inverse model's output. Middle: plant after inverse against the wanted output (ideal: the diagonal). Right: the tracking error.",
  digitized: "Paper 000's digitized view: each operator is one binary digit; the state moves on a hypercube as the input rises and falls.",
  "closed-loop": "Paper 001 Fig. 15–16: a PI controller around the hysteretic plant, without and with the inverse as feedforward.",
  fit: "The fitted model against the uploaded recording, and the residual.",
  diagnosis: "Before and after the diagnosis: the measured loop, the model without and with the effects found, and what each leaves unexplained over time.",
};


// Views drawn from a job's result instead of the session's config (fit, diagnosis).
export const RESULT_VIEWS = ["fit", "diagnosis"];

async function diagnosisFigure() {
  let why = null;
  if (!state.diagFigure) {
    try {
      state.diagFigure = await api("GET", `/api/sessions/${encodeURIComponent(state.code)}/diagnosis/figure`);
    } catch (e) {
      if (e.status !== 409 && e.status !== 404) throw e;
      // the server's reason when it is more than "no diagnosis yet" (a diagnosis stored by
      // an older version, dropped when the session was opened): shown under the plot
      if (e.status === 409 && !/^run the diagnosis first/i.test(e.message)) {
        why = e.message.charAt(0).toUpperCase() + e.message.slice(1);
      }
    }
  }
  return state.diagFigure || { data: [], layout: {
    title: { text: why ? "The stored diagnosis was dropped: the note below says why"
      : "Upload a recording and run the diagnosis to see before and after" },
    meta: { notes: why ? [why] : [] } } };
}

// The request of the figure a view draws (the fit and diagnosis views draw their own
// result beside the loading curve's).
export function figureRequest(fig) {
  const name = RESULT_VIEWS.includes(fig) ? "loading" : fig;
  return api("GET", `/api/sessions/${state.code}/figures?name=${name}`);
}

// Each draw is numbered; one overtaken by a newer draw (another view clicked, a slider moved)
// while it waited for its figure draws nothing, so a slow answer never replaces the newer
// view or shows one view's figure under another's tab.
let drawn = 0;

// A frame painted: what was put on the page before it is on screen.
export function painted() {
  return new Promise((resolve) => requestAnimationFrame(() => setTimeout(resolve, 0)));
}

// ``textFirst`` (a lesson's step): the step's texts, just put on the page, are painted
// before plotly's redraw takes the page's main thread (a class of thirty on one machine:
// the figure came before the next frame and the texts waited on its long task, issue 33).
export async function draw(pending, { textFirst = false } = {}) {
  const seq = ++drawn;
  const first = textFirst ? painted() : null;
  const fig = state.fig;
  const el = $("figure");
  const name = RESULT_VIEWS.includes(fig) ? "loading" : fig;
  const get = () => figureRequest(fig);
  let res = await (pending || get());
  // a figure computed for the view on show when a slider moved; the user may have
  // switched views since: then the view now on show is asked for
  if (!res.figures[name] && seq === drawn) res = await get();
  if (seq !== drawn) return;
  let f = res.figures[name];
  if (fig === "fit") {
    f = state.fitFigure || { data: [], layout: { title: { text: "Upload a recording and fit a model to see the overlay" } } };
  } else if (fig === "diagnosis") {
    f = await diagnosisFigure();
    if (seq !== drawn) return;
  }
  // the status line and the notes under the plot are written first: in projector mode or
  // under a lesson's step the plot takes the height they leave (plots.js fitHeight)
  // the diagnosis view names the diagnosed model, not the session's (fitted) one
  const diagnosed = fig === "diagnosis" && f.layout && f.layout.meta && f.layout.meta.model_title;
  const parts = [diagnosed ? `Diagnosed: ${diagnosed}` : `${res.model_title || res.model_type}`];
  if (!diagnosed) {
    if (res.n_operators !== null && res.n_operators !== undefined) parts.push(`n = ${res.n_operators}`);
    if (res.max_loop_width !== undefined) parts.push(`σ = ${res.max_loop_width.toFixed(4)}`);
    if (res.slopes) parts.push(`slopes ${res.slopes.map((s) => s.toFixed(3)).join(", ")}`);
    if (res.inverse_error) parts.push(`⚠ ${plain(res.inverse_error)}`);
    else if (res.invertible === false) parts.push("⚠ not invertible (a slope ≤ 0)");
    parts.push(`${res.elapsed_ms.toFixed(1)} ms`);
  }
  $("status").textContent = parts.join(" · ");
  const notes = [...(res.model_note ? [res.model_note] : []),
    ...((f.layout && f.layout.meta && f.layout.meta.notes) || [])];
  $("notes").textContent = notes.map((n) => `⚠ ${n}`).join("\n");
  if (first) {
    await first;
    if (seq !== drawn) return;
  }
  const live = performance.now() - state.lastInput < SETTLE_MS;
  // body[data-plotted] names the view and version plotly has drawn (a live move draws a
  // quick plot first and plotly after it settles)
  await render(el, f, { live, stamp: `${fig}@${res.version}` });
  showDigiControls(res);
  document.body.dataset.fig = fig;
  document.body.dataset.ready = String(res.version);
  if (!live) document.body.dataset.settled = String(res.version);
}

// Show view ``name``; ``pending``: its figure, already asked for.
export function selectFigure(name, pending, opts = {}) {
  state.fig = name;
  document.querySelectorAll("#tabs button").forEach((b) => b.classList.toggle("active", b.dataset.fig === name));
  $("view-help").textContent = VIEW_HELP[name] || "";
  draw(pending, opts).catch((e) => setMsg("model-msg", e.message));
}
