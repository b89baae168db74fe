// Hysteresis Explorer web page: talks to the REST API, draws figures with Plotly.react.
// Latest value wins: while a request is in flight, further changes only mark the state
// dirty, and one follow-up request carries the newest values.
// Every string from the server or a file is put in the page as text (textContent,
// new Option), never as markup; the page needs no inline script or style (CSP
// "default-src 'self'").

import { quickPlot } from "/quickplot.js";
import { ModelControls } from "/controls.js";

const $ = (id) => document.getElementById(id);
const state = {
  code: null, config: null, fig: "loop", fitFigure: null, busy: false, dirty: false,
  presets: [], caps: null, events: null, job: null, lastInput: -Infinity, settle: null,
};

// plotly's toolbar without anything that talks to an outside service
const PLOT_CONFIG = {
  responsive: true, displaylogo: false, showLink: false, showSendToCloud: false,
  showEditInChartStudio: false, plotlyServerURL: "", linkText: "",
  modeBarButtonsToRemove: ["sendDataToCloud", "sendChartToCloud", "editInChartStudio"],
  // SVG is written straight from the plot; PNG would load a blob: image, which the
  // server's Content-Security-Policy (default-src 'self') blocks
  toImageButtonOptions: { format: "svg", filename: "hysteresis-explorer" },
};

const VIEW_HELP = {
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

// ---------------------------------------------------------------- tooltips
// Every control says what it does when the pointer rests on it (title); a control that
// brings its own title keeps it. Sliders built later (per operator) are covered too.
const TIPS = {
  "join-code": "The code of a session to continue (shown at the top of the page that uses it)",
  join: "Continue the session whose code you typed",
  "new-session": "Start a fresh session (the current one stays on the server under its code)",
  "my-name": "Shown in the teacher's list of who is connected; your session code is not",
  projector: "Projector mode: the plot's text and the help at least 16 px, to read from the back of a room",
  preset: "Models and inputs taken from the papers' examples",
  "load-preset": "Replace the model and the input by the chosen preset's",
  n: "Number of play operators; thresholds are spread evenly up to the widest, the total weight shared",
  "model-json": "The session's model as JSON: any model type, edited by hand",
  "apply-json": "Use the model typed in the JSON box",
  kind: "Shape of the input signal u(t)",
  amplitude: "Peak value of the input (in the input's unit)",
  frequency: "Cycles per second of the input",
  offset: "Value the input oscillates around",
  duration: "Length of the simulated input",
  samples: "Number of time steps simulated (more: smoother curves, slower)",
  "use-recording": "Drive the model with the uploaded recording's input instead of the signal above",
  mismatch: "Makes the real plant differ from the model: thresholds ×(1+m), weights ×(1−m)",
  "csv-file": "A CSV file with time, input and output columns (any delimiter, decimal comma allowed)",
  "t-col": "The column holding the time stamps",
  "u-col": "The column holding the input (what drove the actuator)",
  "y-col": "The column holding the output (what was measured)",
  "timing-resample": "Interpolate the samples onto evenly spaced time stamps (the step shown)",
  "timing-keep": "Use the time stamps as they are in the file",
  "use-csv": "Load the recording with this column mapping",
  "run-pick": "Which run of the file to use, or all rows as one recording",
  "fit-kind": "Which model type the fit identifies",
  "fit-n": "Number of operators of the fitted model",
  fit: "Fit the chosen model to the recording (it replaces the session's model)",
  diagnose: "Find what the PI model misses in the recording, proved on rows the fit never saw",
  "cancel-job": "Stop the fit or diagnosis; nothing is changed",
  "dl-json": "Download the model as a parameter set (JSON) to continue later",
  "dl-mat": "Download the model for MATLAB / Octave",
  "dl-c": "Download C code of the model and its inverse for a controller",
  "ps-file": "Load a parameter set saved earlier (JSON)",
  "fmi-version": "Which FMI standard the FMU downloads follow (3.0, or 2.0 for older tools)",
  "lesson-new-lesson": "The title of the lesson you are making",
  "lesson-new-title": "The title of the step to add (the current model, input and view)",
  "lesson-new-prompt": "What the class is asked at this step",
  "lesson-new-look": "What the students should look for in the plot",
  "teacher-token": "The token the server was started with (hyst serve --teacher-token)",
  "teacher-preset": "The preset every student gets",
  "teacher-input": "Which input every student gets with it",
  "teacher-push": "Send the chosen model to every student's page now",
  "teacher-push-mine": "Send the model of this page (as you edited it) to every student now",
  "teacher-refresh": "How many pages are open and the names students gave (never their codes)",
  "digi-prev": "One state back along the trace",
  "digi-next": "One state forward along the trace",
  "digi-play": "Walk through the states the input visits, two per second",
  "digi-step": "Which state of the trace the diagram shows",
};
// (the model's sliders carry theirs on their label, from the fields' declarations)
function addTips(root = document) {
  for (const e of root.querySelectorAll("input, select, button, textarea, a.button")) {
    if (e.closest("[title]")) continue;
    const tip = TIPS[e.id] || (e.dataset.fig && VIEW_HELP[e.dataset.fig]);
    if (tip) e.title = tip;
  }
}

// ---------------------------------------------------------------- messages
// Server messages are written for the command line too; a few parts of them name
// arguments or endpoints a page user never sees, so they are rewritten here.
const REWRITES = [
  [/: no such file; to parse CSV text pass a string that contains newlines/,
    " holds a single line: a recording needs a header line and one line per sample"],
  [/;?\s*pass skiprows= to choose yourself/, "; delete the lines above the table"],
  [/if the file starts with a preamble, pass skiprows=/, "if notes stand above the table, delete them"],
  [/pass header=True/, "give the file a header line with the column names"],
  [/pass a larger max_rows= to read it anyway, or cut \/ decimate the recording/, "cut or decimate the recording"],
  [/;?\s*pass a larger max_bytes= to (read it anyway|)/, "; make the file smaller "],
  [/\s*\((GET|POST|PUT|PATCH|DELETE) \/api[^)]*\)/g, ""],
  [/;\s*pass run=<id> to choose another or run=all to read every row/, "; choose another run below"],
  [/\s*\(run=all\)/, ""],
  [/max_operators/g, "the operator limit"],
  [/max_samples/g, "the sample limit"],
];
const STATUS_TEXT = {
  404: "The server does not know this (it may have been restarted).",
  405: "This server does not offer that action (is it an older version?).",
  413: "The file is too large for this server.",
  415: "The file type is not accepted: upload a CSV text file.",
  429: "Too many requests at once: wait a moment and try again.",
  500: "The server hit an unexpected problem. Try again; if it repeats, tell whoever runs it.",
  503: "The server is busy: try again in a moment.",
};

function plain(text) {
  let t = String(text ?? "");
  for (const [re, rep] of REWRITES) t = t.replace(re, rep);
  return t.trim();
}

function detailText(d) {
  if (typeof d === "string") return d;
  if (Array.isArray(d)) {  // FastAPI validation errors: [{loc, msg}]
    return d.map((e) => `${(e.loc || []).filter((x) => x !== "body").join(".")}: ${e.msg}`).join("; ");
  }
  if (d && d.message) return d.message;
  return d === null || d === undefined ? "" : JSON.stringify(d);
}

class ApiError extends Error {
  constructor(status, message, detail = null) { super(message); this.status = status; this.detail = detail; }
}

async function api(method, path, body, type = "application/json") {
  const opts = { method, headers: {} };
  if (body !== undefined) {
    opts.headers["Content-Type"] = type;
    opts.body = typeof body === "string" ? body : JSON.stringify(body);
  }
  if (state.token && path.startsWith("/api/teacher")) opts.headers["X-Teacher-Token"] = state.token;
  let r;
  try {
    r = await fetch(path, opts);
  } catch {
    throw new ApiError(0, "The explorer server cannot be reached: is it still running?");
  }
  const text = await r.text();
  let data = null;
  try { data = text ? JSON.parse(text) : null; } catch { data = text; }
  if (!r.ok) {
    const raw = detailText(data && data.detail !== undefined ? data.detail : data);
    const generic = !raw || /^(Not Found|Method Not Allowed|Internal Server Error)$/.test(raw);
    const msg = generic || r.status >= 500 ? STATUS_TEXT[r.status] || `Request failed (${r.status}).` : plain(raw);
    throw new ApiError(r.status, msg, data && typeof data.detail === "object" ? data.detail : null);
  }
  return data;
}

function setMsg(id, text, ok = false) {
  const el = $(id);
  el.textContent = text || "";
  el.classList.toggle("ok", ok);
  el.classList.remove("rule");
}

function el(tag, props = {}, ...kids) {
  const e = Object.assign(document.createElement(tag), props);
  e.append(...kids.filter((k) => k !== null && k !== undefined && k !== ""));
  return e;
}

function showOutput(input) {
  const out = document.querySelector(`output[for="${input.id}"]`);
  if (out) out.textContent = Number(input.value).toFixed(3).replace(/\.?0+$/, "");
}

// ---------------------------------------------------------------- controls <-> config
// The model's sliders come from the server's description of the model (static/controls.js);
// the JSON box follows them, so Apply never undoes a slider.
let controls = null;

function showModelJson(model) {
  const box = $("model-json");
  if (document.activeElement !== box) box.value = JSON.stringify(model, null, 1);
}

// What a slider's rule changed (r3 stopped just below r4) stays on show until the next move.
function showNote(note) {
  state.note = note;
  setMsg("model-msg", note);
  $("model-msg").classList.toggle("rule", Boolean(note));
}

function onSliderMoved(note) {
  showModelJson(controls.model);
  showNote(note);
  onControlChange();
}

function applyConfig(cfg, version, { fresh = false } = {}) {
  state.config = cfg;
  state.note = "";
  if (version !== undefined) state.version = version;
  const m = cfg.model;
  const isPI = m.type === "pi";
  $("pi-controls").hidden = !isPI;
  if (isPI) $("n").value = m.thresholds.length;
  controls.show(m).catch((e) => setMsg("model-msg", e.message));
  for (const k of ["amplitude", "frequency", "offset", "duration"]) $(k).value = cfg.signal[k];
  $("kind").value = cfg.signal.kind;
  $("samples").value = cfg.signal.samples;
  $("mismatch").value = cfg.mismatch;
  $("model-json").value = JSON.stringify(m, null, 1);
  $("use-recording").checked = cfg.use_recording;
  document.querySelectorAll("aside input[type=range]").forEach(showOutput);
  syncPreset(m, { fresh });
}

function readConfig() {
  const cfg = structuredClone(state.config);
  if (controls.model) cfg.model = structuredClone(controls.model);
  for (const k of ["amplitude", "frequency", "offset", "duration"]) cfg.signal[k] = Number($(k).value);
  cfg.signal.kind = $("kind").value;
  cfg.signal.samples = Number($("samples").value);
  cfg.mismatch = Number($("mismatch").value);
  cfg.use_recording = $("use-recording").checked;
  return cfg;
}

function onControlChange() {
  state.lastInput = performance.now();
  state.dirty = true;
  pump();
}

// One request at a time; the newest control values win.
async function pump() {
  if (state.busy) return;
  state.busy = true;
  try {
    while (state.dirty) {
      state.dirty = false;
      const cfg = readConfig();
      // store the change and, for a simulated input, compute the figure from the same
      // config at the same time (one round trip instead of two)
      const stored = api("PATCH", `/api/sessions/${state.code}/config`, cfg);
      const name = RESULT_VIEWS.includes(state.fig) ? "loading" : state.fig;
      const figure = cfg.use_recording || RESULT_VIEWS.includes(state.fig) ? null
        : api("POST", "/api/simulate", { model: cfg.model, signal: cfg.signal,
          mismatch: cfg.mismatch, figures: [name] });
      if (figure) figure.catch(() => null);  // a refused config is reported by the PATCH
      try {
        const s = await stored;
        state.config = s.config;
        state.version = s.version;
        showNote(state.note || "");
      } catch (e) {
        // back to the last accepted model, so that the next move starts from it
        controls.revert(state.config.model);
        showModelJson(state.config.model);
        showNote("");
        setMsg("model-msg", `Not applied: ${e.message} The sliders are back at the last accepted values.`);
        continue;
      }
      await draw(figure ? figure.then((r) => ({ ...r, version: state.version })) : undefined);
    }
  } finally {
    state.busy = false;
  }
}

// On a phone the side-by-side panels of a figure are stacked: the axes of each column
// (x axes sharing a horizontal domain) get a band of the height, top to bottom.
function fitLayout(layout) {
  const fig = $("figure");
  const keys = Object.keys(layout);
  const xs = keys.filter((k) => /^xaxis\d*$/.test(k));
  const cols = [], colOf = {};
  for (const k of xs) {
    const d = JSON.stringify(layout[k].domain || [0, 1]);
    if (!cols.includes(d)) cols.push(d);
    colOf[k] = cols.indexOf(d);
  }
  const stack = fig.clientWidth < 600 && cols.length > 1;
  fig.classList.toggle("tall", stack);
  if (!stack) return layout;
  const lay = structuredClone(layout);
  const band = 1 / cols.length, gap = 0.25 * band;  // room for tick labels and a title
  for (const k of xs) lay[k].domain = [0, 1];
  for (const k of keys.filter((k) => /^yaxis\d*$/.test(k))) {
    const anchor = String(lay[k].anchor || "x");
    const c = colOf["xaxis" + (anchor.startsWith("x") ? anchor.slice(1) : "")] ?? 0;
    const [a, b] = lay[k].domain || [0, 1];
    const top = 1 - c * band, bottom = top - band + gap;
    lay[k].domain = [bottom + a * (top - bottom), bottom + b * (top - bottom)];
  }
  lay.margin = { ...(lay.margin || {}), l: 50, r: 10 };
  // side notes in monospace (the digitized view's matrices) have no room left
  lay.annotations = (lay.annotations || []).filter((a) => !(a.font && a.font.family === "monospace"));
  lay.showlegend = false;
  if (lay.title) lay.title = { ...lay.title, font: { size: 11 } };
  return lay;
}

// plotly.js is loaded after the first figure is on screen (quickplot.js draws it);
// from then on every figure is drawn by plotly
let plotlyLoading = null;
function loadPlotly() {
  plotlyLoading ??= new Promise((resolve, reject) => {
    const s = Object.assign(document.createElement("script"), { src: "/vendor/plotly.min.js" });
    s.addEventListener("load", resolve);
    s.addEventListener("error", () => reject(new Error("the plotting library did not load")));
    document.head.append(s);
  });
  return plotlyLoading;
}

// While a control is being moved, plotly's redraw (30-200 ms for these figures) is the
// slow part of a step: the frames of a drag are drawn by quickplot.js over the plot, and
// plotly redraws once the control has rested for SETTLE_MS (keeping zoom and toolbar).
const SETTLE_MS = 350;

function zoomed(layout) {
  const fl = $("figure")._fullLayout;
  if (!fl) return layout;
  const lay = { ...layout };
  for (const k of Object.keys(lay)) {
    if (/^[xy]axis\d*$/.test(k) && fl[k] && fl[k].autorange === false && Array.isArray(fl[k].range)) {
      lay[k] = { ...lay[k], range: fl[k].range.slice() };
    }
  }
  return lay;
}

// Projector mode: every text of the plot at least 16 px (app/services/figures.py's
// large_text does the same for viser).
function largeText(layout, size = 16) {
  const lay = structuredClone(layout);
  lay.font = { ...(lay.font || {}), size };
  if (lay.title && typeof lay.title === "object") lay.title = { ...lay.title, font: { ...(lay.title.font || {}), size: size + 4 } };
  lay.legend = { ...(lay.legend || {}), font: { size } };
  for (const k of Object.keys(lay)) {
    if (!/^[xy]axis\d*$/.test(k) || !lay[k]) continue;
    lay[k] = { ...lay[k], tickfont: { ...(lay[k].tickfont || {}), size } };
    if (lay[k].title && typeof lay[k].title === "object") {
      lay[k].title = { ...lay[k].title, font: { ...(lay[k].title.font || {}), size: size + 2 } };
    }
  }
  lay.annotations = (lay.annotations || []).map((a) => ({ ...a, font: { ...(a.font || {}), size: Math.max(size, (a.font && a.font.size) || 0) } }));
  return lay;
}

function setProjector(on) {
  document.body.classList.toggle("projector", on);
  $("projector").setAttribute("aria-pressed", String(on));
  localStorage.setItem("hyst-projector", on ? "1" : "");
  if (state.shown) render($("figure"), state.shown).catch((e) => setMsg("model-msg", e.message));
}

async function render(el, f, { live = false } = {}) {
  state.shown = f;
  let layout = fitLayout(f.layout);
  if (document.body.classList.contains("projector")) layout = largeText(layout);
  const old = el.querySelector(":scope > .quick-plot");
  if (!window.Plotly || live) {
    const svg = quickPlot(el, f.data, window.Plotly ? zoomed(layout) : layout);
    if (window.Plotly) {
      svg.classList.add("overlay");
      if (old) old.replaceWith(svg); else el.append(svg);
      el.classList.add("live");  // plotly's own SVG is hidden (not repainted) meanwhile
      clearTimeout(state.settle);
      state.settle = setTimeout(() => {
        render(el, state.shown).catch((e) => setMsg("model-msg", e.message));
      }, SETTLE_MS);
    } else {
      el.replaceChildren(svg);
    }
    return;
  }
  clearTimeout(state.settle);
  if (old && !old.classList.contains("overlay")) el.replaceChildren();
  const t0 = performance.now();
  await Plotly.react(el, f.data, layout, PLOT_CONFIG);
  if (old && old.classList.contains("overlay")) old.remove();
  el.classList.remove("live");
  document.body.dataset.plotlyMs = (performance.now() - t0).toFixed(1);
  document.body.dataset.settled = document.body.dataset.ready || "";
}

// Views drawn from a job's result instead of the session's config (fit, diagnosis).
const RESULT_VIEWS = ["fit", "diagnosis"];

async function diagnosisFigure() {
  if (!state.diagFigure) {
    try {
      state.diagFigure = await api("GET", `/api/sessions/${encodeURIComponent(state.code)}/diagnosis/figure`);
    } catch (e) {
      if (e.status !== 409 && e.status !== 404) throw e;
    }
  }
  return state.diagFigure || { data: [], layout: { title: { text: "Upload a recording and run the diagnosis to see before and after" } } };
}

async function draw(pending) {
  const el = $("figure");
  const name = RESULT_VIEWS.includes(state.fig) ? "loading" : state.fig;
  const get = () => api("GET", `/api/sessions/${state.code}/figures?name=${name}`);
  let res = await (pending || get());
  // a figure computed for the view on show when a slider moved; the user may have
  // switched views since: then the view now on show is asked for
  if (!res.figures[name]) res = await get();
  let f = res.figures[name];
  if (state.fig === "fit") {
    f = state.fitFigure || { data: [], layout: { title: { text: "Upload a recording and fit a model to see the overlay" } } };
  } else if (state.fig === "diagnosis") {
    f = await diagnosisFigure();
  }
  const live = performance.now() - state.lastInput < SETTLE_MS;
  await render(el, f, { live });
  const parts = [`${res.model_type}`];
  if (res.n_operators !== null && res.n_operators !== undefined) parts.push(`n = ${res.n_operators}`);
  if (res.max_loop_width !== undefined) parts.push(`σ = ${res.max_loop_width.toFixed(4)}`);
  if (res.slopes) parts.push(`slopes ${res.slopes.map((s) => s.toFixed(3)).join(", ")}`);
  if (res.inverse_error) parts.push(`⚠ ${plain(res.inverse_error)}`);
  else if (res.invertible === false) parts.push("⚠ not invertible (a slope ≤ 0)");
  $("status").textContent = parts.join(" · ") + ` · ${res.elapsed_ms.toFixed(1)} ms`;
  showDigiControls(res);
  const notes = (f.layout && f.layout.meta && f.layout.meta.notes) || [];
  $("notes").textContent = notes.map((n) => `⚠ ${n}`).join("\n");
  document.body.dataset.fig = state.fig;
  document.body.dataset.ready = String(res.version);
  if (!live) document.body.dataset.settled = String(res.version);
}

// ---------------------------------------------------------------- digitized step / play
// The digitized view at one state of its trace: the server draws it (?state=k); Play
// steps through the trace at 2 states per second.
const DIGI_PLAY_MS = 500;

function showDigiControls(res) {
  const n = state.fig === "digitized" ? res.digitized_states : undefined;
  $("digi-controls").hidden = !n;
  if (!n) { stopPlay(); return; }
  const step = $("digi-step");
  step.max = String(n - 1);
  if (!state.digiTimer) {  // a freshly drawn figure shows the final state
    step.value = String(n - 1);
    state.digiStep = null;
  }
  showOutput(step);
}

async function showState(k) {
  const step = $("digi-step");
  k = Math.max(0, Math.min(Number(step.max), k));
  step.value = String(k);
  state.digiStep = k;
  showOutput(step);
  const res = await api("GET", `/api/sessions/${encodeURIComponent(state.code)}/figures?name=digitized&state=${k}`);
  if (state.fig !== "digitized") return;
  await render($("figure"), res.figures.digitized);
  document.body.dataset.digiState = String(k);
}

function stopPlay() {
  clearInterval(state.digiTimer);
  state.digiTimer = null;
  $("digi-play").textContent = "Play from the start";
}

function togglePlay() {
  if (state.digiTimer) { stopPlay(); return; }
  $("digi-play").textContent = "Stop";
  let k = 0;
  const tick = () => {
    if (k > Number($("digi-step").max) || state.fig !== "digitized") { stopPlay(); return; }
    showState(k++).catch((e) => { stopPlay(); setMsg("model-msg", e.message); });
  };
  tick();
  state.digiTimer = setInterval(tick, DIGI_PLAY_MS);
}

// ---------------------------------------------------------------- session
async function openSession(code, { create = false } = {}) {
  let s;
  if (!code) s = await api("POST", "/api/sessions");
  else if (create) s = await api("PUT", `/api/sessions/${encodeURIComponent(code)}`);
  else s = await api("GET", `/api/sessions/${encodeURIComponent(code)}`);
  state.code = s.code;
  state.diagFigure = null;
  state.fitFigure = null;
  localStorage.setItem("hyst-session", s.code);
  $("code").textContent = s.code;
  for (const f of ["json", "mat", "c"]) $(`dl-${f}`).href = `/api/sessions/${encodeURIComponent(s.code)}/export/${f}`;
  fmuLinks();
  applyConfig(s.config, s.version, { fresh: true });
  listen();
  await draw();
  resumeJob().catch((e) => setMsg("csv-msg", e.message));
}

// The FMU downloads follow the FMI version chosen (the server compiles them on demand).
function fmuLinks() {
  const base = `/api/sessions/${encodeURIComponent(state.code)}/export/fmu?fmi=${$("fmi-version").value}`;
  $("dl-fmu-inv").href = `${base}&inverse=true`;
  $("dl-fmu-fwd").href = `${base}&inverse=false`;
}

// An FMU is compiled on the server (a second or so) and may be refused (a model without an
// inverse, a busy server): fetch it, and say why when there is no file.
async function downloadFmu(ev) {
  ev.preventDefault();
  const link = ev.currentTarget;
  setMsg("export-msg", "building the FMU…");
  let r;
  try {
    r = await fetch(link.href);
  } catch {
    setMsg("export-msg", "The explorer server cannot be reached: is it still running?");
    return;
  }
  if (!r.ok) {
    let detail = "";
    try { detail = detailText((await r.json()).detail); } catch { /* not JSON */ }
    setMsg("export-msg", `No FMU: ${detail && r.status < 500 ? plain(detail) : STATUS_TEXT[r.status] || `error ${r.status}`}`);
    return;
  }
  const blob = await r.blob();
  const m = /filename="?([^";]+)"?/.exec(r.headers.get("Content-Disposition") || "");
  const name = m ? m[1] : "hysteresis.fmu";
  const a = el("a", { href: URL.createObjectURL(blob), download: name });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  setMsg("export-msg", `Downloaded ${name} (${blob.size} bytes)`, true);
}

// Live events: a teacher push reloads the session; the note says what happened.
function listen() {
  if (state.events) state.events.close();
  if (!window.EventSource) return;
  const name = ($("my-name").value || "").trim();
  const q = name ? `?name=${encodeURIComponent(name)}` : "";
  const es = new EventSource(`/api/sessions/${encodeURIComponent(state.code)}/events${q}`);
  es.addEventListener("push", (ev) => {
    let info = {};
    try { info = JSON.parse(ev.data); } catch { /* keep the defaults */ }
    onPushed(info).then(() => tell("hyst:push", info)).catch((e) => setMsg("model-msg", e.message));
  });
  es.addEventListener("lesson", (ev) => tell("hyst:lesson", JSON.parse(ev.data)));
  state.events = es;
}

async function onPushed(info) {
  const s = await api("GET", `/api/sessions/${encodeURIComponent(state.code)}`);
  applyConfig(s.config, s.version);
  // a change of ours still in flight was based on the old model: send the pushed one
  if (state.busy) state.dirty = true;
  const p = state.presets.find((x) => x.name === info.preset);
  const what = p ? p.title : info.title || info.preset || (info.model === false ? "a new input" : "a model");
  const note = $("live-note");
  note.textContent = `Your teacher pushed ${what}${info.signal ? " with its input" : ""}` +
    ` at ${new Date().toLocaleTimeString()}. Your sliders now start from it.`;
  note.hidden = false;
  await draw();
}

// ---------------------------------------------------------------- data
let csvText = null, csvName = "upload.csv";

async function onCsvChosen(ev) {
  const file = ev.target.files[0];
  if (!file) return;
  csvText = await file.text();
  csvName = file.name;
  try {
    const p = await api("POST", "/api/csv/preview", csvText, "text/csv");
    const head = el("tr", {}, ...p.columns.map((c) => el("th", { textContent: String(c) })));
    const rows = p.rows.map((r) => el("tr", {}, ...r.map((v) => el("td", { textContent: String(v) }))));
    $("preview").replaceChildren(head, ...rows);
    for (const [id, guess] of [["t-col", 0], ["u-col", 1], ["y-col", 2]]) {
      const sel = $(id);
      sel.replaceChildren(...(id === "t-col" ? [new Option("(automatic: time column, else 1 ms steps)", "")] : []),
        ...p.columns.map((c, i) => new Option(String(c), String(i))));
      // "u", "input", or a name with a unit such as "u_V" / "y_um" / "t_s"
      const [role, word] = { "t-col": ["t", "time"], "u-col": ["u", "input"], "y-col": ["y", "output"] }[id];
      const idx = p.columns.findIndex((c) => {
        const name = String(c).toLowerCase();
        return name === role || name === word || name.startsWith(`${role}_`) || name.startsWith(`${word}_`);
      });
      const roleNamed = p.columns.some((c) => /^(u|y|input|output)(_|$)/i.test(String(c)));
      const fallback = id === "t-col" && roleNamed ? "" : String(Math.min(guess, p.columns.length - 1));
      sel.value = idx >= 0 ? String(idx) : fallback;
    }
    showTiming(p.uneven);
    $("mapping").hidden = false;
    $("runs").hidden = true;
    $("csv-notes").replaceChildren(...(p.notes || []).map((n) => el("li", { textContent: plain(n) })));
    setMsg("csv-msg", `${p.n_rows} rows, ${p.columns.length} columns: check the mapping`, true);
  } catch (e) {
    $("mapping").hidden = true;
    setMsg("csv-msg", `CSV not readable: ${e.message}`);
  }
}

// The upload says what the reader cleaned (removed rows, skipped lines, the run kept);
// a file with a run column gets a picker: one run, or every row as one recording.
async function useCsv(run) {
  const q = new URLSearchParams({ name: csvName.slice(0, 200) });
  for (const [id, key] of [["t-col", "t_col"], ["u-col", "u_col"], ["y-col", "y_col"]]) {
    if ($(id).value !== "") q.set(key, $(id).value);
  }
  if (typeof run === "string") q.set("run", run);
  if (!$("timing").hidden) {
    const choice = $("timing-keep").checked ? "keep" : "resample";
    q.set("timing", choice);
    if (choice === "resample") q.set("step", String(state.timing.step_s));
  }
  try {
    const r = await api("POST", `/api/sessions/${encodeURIComponent(state.code)}/recording?${q}`, csvText, "text/csv");
    setMsg("csv-msg", `Loaded ${r.name}: ${r.samples} samples${r.time_steps ? `; ${r.time_steps}` : ""}.`, true);
    state.diagFigure = null;  // the diagnosis of another recording is gone
    $("csv-notes").replaceChildren(...(r.notes || []).map((n) => el("li", { textContent: plain(n) })));
    showRuns(r.runs || [], run === "all" ? "all" : r.run);
    $("use-recording").checked = true;
    onControlChange();
  } catch (e) {
    if (e.detail && e.detail.uneven) {  // another time column, found uneven: offer the choice
      showTiming(e.detail.uneven);
      setMsg("csv-msg", "CSV not loaded yet: its time stamps are uneven. Choose below whether to resample or keep them, then click \u201cUse this mapping\u201d again.");
      return;
    }
    setMsg("csv-msg", `CSV not loaded: ${e.message}`);
  }
}

// Uneven time stamps: the upload resamples them onto the step shown, or keeps them.
function seconds(s) {
  const v = Number(Number(s).toPrecision(3));
  for (const [unit, scale] of [["s", 1], ["ms", 1e-3], ["µs", 1e-6]]) {
    if (Math.abs(v) >= scale) return `${Number((v / scale).toPrecision(3))} ${unit}`;
  }
  return `${Number((v / 1e-9).toPrecision(3))} ns`;
}

function showTiming(uneven) {
  state.timing = uneven || null;
  $("timing").hidden = !uneven;
  if (!uneven) return;
  $("timing-what").textContent = `The time stamps in column \u201c${uneven.column}\u201d are uneven: ` +
    `the spacing varies from ${seconds(uneven.spacing_min_s)} to ${seconds(uneven.spacing_max_s)} ` +
    `(mean ${seconds(uneven.spacing_mean_s)}). Choose what the upload does with them:`;
  $("timing-resample-text").textContent = `resample onto an even grid of ${seconds(uneven.step_s)} steps (linear interpolation)`;
}

function showRuns(runs, kept) {
  const pick = $("run-pick");
  $("runs").hidden = runs.length < 2;
  if (runs.length < 2) return;
  pick.replaceChildren(...runs.map((r) => new Option(`run ${r}`, String(r))),
    new Option(`all ${runs.length} runs as one recording`, "all"));
  pick.value = kept === null || kept === undefined ? String(runs[0]) : String(kept);
}

// Long work (fit, diagnosis): one at a time, the buttons are disabled and a note counts
// the seconds. A server with the jobs API runs it as a job (progress, cancel); an older
// one answers the plain endpoint. ``running`` is a job already queued or running (found
// by resumeJob after a reload): it is followed instead of starting a new one.
async function runJob(kind, params, syncPath, syncBody, running = null) {
  if (state.job) return null;
  const buttons = [$("fit"), $("diagnose")];
  buttons.forEach((b) => { b.disabled = true; });
  // a new run replaces what the last one said (a "cancelled" or "failed" line)
  if (state.jobSaid) { setMsg("csv-msg", ""); state.jobSaid = false; }
  const busy = $("busy"), bar = $("job-progress"), cancel = $("cancel-job");
  const t0 = performance.now();
  const label = (kind === "fit" ? "Fitting" : "Diagnosing") +
    (running ? " (started before this page was loaded)" : "");
  let progress = null, message = "";
  const tick = () => {
    const s = ((performance.now() - t0) / 1000).toFixed(0);
    const pct = progress === null ? "" : `${Math.round(100 * progress)} %, `;
    busy.textContent = `${label}… working, ${pct}${s} s${message ? ` (${message})` : ""}`;
  };
  state.job = { kind };
  busy.hidden = false;
  tick();
  const timer = setInterval(tick, 500);
  try {
    let job = running;
    if (!job && state.noJobs) return await api("POST", syncPath, syncBody);
    if (!job) {
      try {
        job = await api("POST", `/api/sessions/${state.code}/jobs`, { kind, params });
      } catch (e) {
        if (e.status !== 404 && e.status !== 405) throw e;
        state.noJobs = true;  // a server without the jobs API: its plain endpoints
        return await api("POST", syncPath, syncBody);
      }
    }
    state.job.id = job.id;
    const jobPath = `/api/sessions/${encodeURIComponent(state.code)}/jobs/${encodeURIComponent(job.id)}`;
    bar.value = typeof job.progress === "number" ? job.progress : 0;
    cancel.disabled = false;
    cancel.textContent = "Cancel";
    cancel.hidden = false;
    bar.hidden = false;
    let misses = 0;
    for (;;) {
      await new Promise((r) => setTimeout(r, 400));
      try {
        job = await api("GET", jobPath);
        misses = 0;
      } catch (e) {
        // a busy server or a dropped connection: keep asking a few times, then give up
        // (and cancel the job, so the session is free for the next one)
        if (e.status === 404 || ++misses >= 5) {
          api("DELETE", jobPath).catch(() => null);
          throw e;
        }
        continue;
      }
      progress = typeof job.progress === "number" ? job.progress : null;
      if (progress !== null) bar.value = progress;
      message = job.message ? plain(job.message) : "";
      tick();
      if (job.state === "done") return job.result;
      if (job.state === "failed") throw new ApiError(422, plain(job.error || "the job failed"));
      if (job.state === "cancelled") throw new JobCancelled(plain(job.message));
    }
  } finally {
    clearInterval(timer);
    busy.hidden = true;
    bar.hidden = true;
    cancel.hidden = true;
    cancel.disabled = false;
    buttons.forEach((b) => { b.disabled = false; });
    state.job = null;
  }
}

class JobCancelled extends Error {}

// A page opened (or reloaded) while its session has a fit or diagnosis queued or running
// follows that job: progress, Cancel, and its result when it is done.
async function resumeJob() {
  if (state.job || state.noJobs) return;
  let r;
  try {
    r = await api("GET", `/api/sessions/${encodeURIComponent(state.code)}/jobs?limit=1`);
  } catch {
    return;  // an older server without the list: nothing to follow
  }
  const job = r && Array.isArray(r.jobs) ? r.jobs[0] : null;
  if (!job || (job.state !== "queued" && job.state !== "running")) return;
  if (job.kind === "fit") await fit(job);
  else if (job.kind === "diagnose") await diagnose(job);
}

// The job stops at its next progress report; runJob's polling sees it end "cancelled".
async function cancelJob() {
  const job = state.job;
  if (!job || !job.id) return;
  const cancel = $("cancel-job");
  cancel.disabled = true;
  cancel.textContent = "Cancelling…";
  try {
    await api("DELETE", `/api/sessions/${encodeURIComponent(state.code)}/jobs/${encodeURIComponent(job.id)}`);
  } catch (e) {
    cancel.disabled = false;
    cancel.textContent = "Cancel";
    setMsg("csv-msg", `Not cancelled: ${e.message}`);
  }
}

// What a failed or cancelled fit / diagnosis says under the Data section.
function jobFailed(what, e) {
  state.jobSaid = true;
  if (e instanceof JobCancelled) {
    setMsg("csv-msg", `${what} cancelled: nothing was changed.`, true);
  } else {
    setMsg("csv-msg", `${what} failed: ${e.message}`);
  }
}

async function fit(running = null) {
  const params = { n: Number($("fit-n").value), kind: $("fit-kind").value };
  try {
    const r = await runJob("fit", params, `/api/sessions/${state.code}/fit`, params, running);
    if (!r) return;
    state.fitFigure = r.figure;
    const rep = r.report;
    // the fit report's warnings (e.g. a held-out error far above the noise floor, and where)
    const warned = (rep.warnings || []).map((w) => el("p", { className: "msg", textContent: `Warning: ${w}` }));
    $("report").replaceChildren(el("p", {
      className: "msg ok",
      textContent: `Fit: RMS error ${rep.rms_error.toPrecision(4)}, ${rep.nrmse_percent.toPrecision(3)} % of range`,
    }), ...warned);
    const s = await api("GET", `/api/sessions/${state.code}`);
    applyConfig(s.config, s.version);
    selectFigure("fit");
  } catch (e) {
    $("report").replaceChildren();
    jobFailed("Fit", e);
  }
}

async function diagnose(running = null) {
  try {
    const r = await runJob("diagnose", {}, `/api/sessions/${state.code}/diagnose`, undefined, running);
    if (!r) return;
    // the findings are sentences with units, written by the server for people
    const items = (r.findings || []).map((f) => el("li", { textContent: typeof f === "string" ? f : JSON.stringify(f) }));
    const box = el("div", { id: "diagnosis" }, el("h3", { textContent: "Diagnosis" }),
      el("ul", {}, ...items));
    if (r.document) {
      box.append(el("a", {
        href: `/api/sessions/${encodeURIComponent(state.code)}/diagnosis/report.html`,
        target: "_blank", rel: "noopener", textContent: "full report (HTML)",
      }));
    }
    $("report").replaceChildren(box);
    state.diagFigure = null;  // this run's before / after
    selectFigure("diagnosis");
  } catch (e) {
    jobFailed("Diagnosis", e);
  }
}

async function onParamSetChosen(ev) {
  const file = ev.target.files[0];
  if (!file) return;
  try {
    // the file's text is the body as it is (a saved parameter set or a bare model)
    const s = await api("PUT", `/api/sessions/${state.code}/parameter-set`, await file.text());
    applyConfig(s.config, s.version);
    await draw();
    setMsg("export-msg", `Loaded ${file.name}`, true);
  } catch (e) {
    setMsg("export-msg", `Not loaded: ${e.message}`);
  } finally {
    ev.target.value = "";
  }
}

function selectFigure(name) {
  state.fig = name;
  document.querySelectorAll("#tabs button").forEach((b) => b.classList.toggle("active", b.dataset.fig === name));
  $("view-help").textContent = VIEW_HELP[name] || "";
  draw().catch((e) => setMsg("model-msg", e.message));
}

function showPresetDesc() {
  const p = state.presets.find((x) => x.name === $("preset").value);
  let text = p ? p.description : "";
  if (p && state.presetChanged) text = `The session's model started from this preset and was changed since. ${text}`;
  else if (!p && $("preset").value === CHANGED) text = "The session's model is not one of the presets (changed with the sliders, the JSON, a fit or a saved set); pick a preset to start over.";
  $("preset-desc").textContent = text;
}

// The preset dropdown shows the session's preset (after a reload, a rejoin or a push):
// the preset whose model is the session's; on a freshly opened page whose model was
// changed, the preset this browser last loaded into the session, else "a changed model".
const CHANGED = "";
function canonical(v) {
  if (Array.isArray(v)) return `[${v.map(canonical).join(",")}]`;
  if (v && typeof v === "object") {
    return `{${Object.keys(v).sort().map((k) => `${JSON.stringify(k)}:${canonical(v[k])}`).join(",")}}`;
  }
  return JSON.stringify(v);
}

function syncPreset(model, { fresh = false } = {}) {
  const key = `hyst-preset:${state.code}`;
  const want = canonical(model);
  const match = state.presets.find((p) => canonical(p.model) === want);
  const sel = $("preset");
  const placeholder = sel.querySelector(`option[value="${CHANGED}"]`);
  let name = null;
  state.presetChanged = false;
  if (match) {
    name = match.name;
    localStorage.setItem(key, name);
  } else if (fresh) {
    const remembered = localStorage.getItem(key);
    if (state.presets.some((p) => p.name === remembered)) {
      name = remembered;
      state.presetChanged = true;
    } else {
      name = CHANGED;
    }
  }
  if (name === null) return;
  if (name === CHANGED && !placeholder) sel.prepend(new Option("(a changed model)", CHANGED));
  if (name !== CHANGED && placeholder) placeholder.remove();
  sel.value = name;
  showPresetDesc();
}

async function loadPreset() {
  const p = state.presets.find((x) => x.name === $("preset").value);
  if (!p) { setMsg("model-msg", "Pick a preset in the list first."); return; }
  try {
    const s = await api("PATCH", `/api/sessions/${state.code}/config`,
      { model: p.model, signal: p.input, use_recording: false });
    applyConfig(s.config, s.version);
    setMsg("model-msg", `Loaded: ${p.title}`, true);
    await draw();
  } catch (e) {
    setMsg("model-msg", `Not loaded: ${e.message}`);
  }
}

// ---------------------------------------------------------------- teacher
async function teacherPush(ev) {
  state.token = $("teacher-token").value;
  try {
    const mode = $("teacher-input").value;
    const mine = ev && ev.target && ev.target.id === "teacher-push-mine";
    const body = mine ? { model: readConfig().model }
      : { preset: $("teacher-preset").value, use_preset_input: mode === "preset" };
    if (mode === "mine") body.signal = readConfig().signal;
    const r = await api("POST", "/api/teacher/push", body);
    setMsg("teacher-msg", `Pushed to ${r.sessions} sessions (${r.pages} open pages).`, true);
  } catch (e) {
    setMsg("teacher-msg", e.status === 403 ? "Wrong teacher token." : `Not pushed: ${e.message}`);
  }
}

async function teacherRefresh() {
  state.token = $("teacher-token").value;
  try {
    const r = await api("GET", "/api/teacher/connected");
    // counts and names only: a projected panel must not show the session codes
    setMsg("teacher-msg", r.text || `Connected: ${r.pages} open pages in ${r.sessions_live} of ${r.sessions} sessions.`, true);
  } catch (e) {
    setMsg("teacher-msg", e.status === 403 ? "Wrong teacher token." : e.message);
  }
}

// ---------------------------------------------------------------- for static/lesson.js
// The lesson mode (static/lesson.js) drives the page through these and hears the live
// events as window events ("hyst:push" after a push is shown, "hyst:lesson").
export const explorer = { state, api, applyConfig, draw, selectFigure, setMsg };
function tell(name, detail) { window.dispatchEvent(new CustomEvent(name, { detail })); }

// ---------------------------------------------------------------- start
async function main() {
  controls = new ModelControls($("model-controls"), { api, onChange: onSliderMoved });
  const [caps, presets, v] = await Promise.all([
    api("GET", "/api/capabilities"), api("GET", "/api/presets"), api("GET", "/api/viser-url")]);
  state.caps = caps;
  state.presets = presets;
  $("kind").replaceChildren(...caps.signals.map((s) => new Option(s.replace(/_/g, " "), s)));
  for (const id of ["preset", "teacher-preset"]) {
    $(id).replaceChildren(...presets.map((p) => new Option(p.title, p.name)));
  }
  showPresetDesc();
  $("fit-kind").replaceChildren(...caps.fit_kinds.map((k) => new Option(k, k)));
  $("samples").max = caps.limits.max_samples;
  $("n").max = caps.limits.max_operators;
  $("fit-n").max = caps.limits.max_operators;
  if (v.enabled) {
    const link = $("viser-link");
    link.href = `${location.protocol}//${location.hostname}:${v.port}/`;
    link.hidden = false;
  }
  for (const id of ["amplitude", "frequency", "offset", "duration", "mismatch"]) {
    $(id).addEventListener("input", () => { showOutput($(id)); onControlChange(); });
  }
  for (const id of ["kind", "samples", "use-recording"]) $(id).addEventListener("change", onControlChange);
  $("n").addEventListener("change", () => {
    const max = caps.limits.max_operators;
    const asked = Math.round(Number($("n").value));
    const n = Math.max(1, Math.min(Number.isFinite(asked) ? asked : 1, max));
    $("n").value = n;
    showNote(n === asked ? "" : asked > max
      ? `This server allows at most ${max} operators: n is set to ${max}.`
      : `n must be a whole number from 1 to ${max}: n is set to ${n}.`);
    const m = structuredClone(controls.model || state.config.model);
    const rmax = m.thresholds[m.thresholds.length - 1];
    const total = m.weights.reduce((a, b) => a + b, 0);
    m.thresholds = Array.from({ length: n }, (_, i) => (rmax * (i + 1)) / n);
    m.weights = Array(n).fill(total / n);
    delete m.state0;
    controls.show(m).catch((e) => setMsg("model-msg", e.message));
    showModelJson(m);
    onControlChange();
  });
  $("preset").addEventListener("change", () => { state.presetChanged = false; showPresetDesc(); });
  $("load-preset").addEventListener("click", loadPreset);
  const join = async () => {
    const code = $("join-code").value.trim();
    if (!code) { setMsg("model-msg", "Type the session code first."); return; }
    try {
      await openSession(code);
      setMsg("model-msg", `Joined session ${code}.`, true);
    } catch (e) {
      setMsg("model-msg", e.status === 404 || e.status === 422
        ? `No session "${code}" on this server: the code may be mistyped (it looks like abcd-efgh-jkmn-pqrs and is shown at the top of the page that uses it) or the session has expired. You are still in session ${state.code}.`
        : e.message);
    }
  };
  $("join").addEventListener("click", join);
  $("my-name").value = localStorage.getItem("hyst-name") || "";
  $("projector").addEventListener("click", () => setProjector(!document.body.classList.contains("projector")));
  if (localStorage.getItem("hyst-projector")) setProjector(true);
  $("my-name").addEventListener("change", () => {
    localStorage.setItem("hyst-name", $("my-name").value.trim());
    if (state.code) listen();  // the teacher's list shows the new name
  });
  $("join-code").addEventListener("keydown", (e) => { if (e.key === "Enter") join(); });
  $("new-session").addEventListener("click", () => openSession(null).catch((e) => setMsg("model-msg", e.message)));
  $("apply-json").addEventListener("click", async () => {
    let model;
    try { model = JSON.parse($("model-json").value); } catch (e) {
      setMsg("model-msg", `Not valid JSON: ${e.message}`);
      return;
    }
    try {
      const s = await api("PATCH", `/api/sessions/${state.code}/config`, { model });
      applyConfig(s.config, s.version);
      setMsg("model-msg", "");
      await draw();
    } catch (e) {
      setMsg("model-msg", `Not applied: ${e.message}`);
    }
  });
  $("csv-file").addEventListener("change", onCsvChosen);
  $("use-csv").addEventListener("click", () => useCsv());
  $("t-col").addEventListener("change", () => showTiming(null));  // asked again if uneven
  $("run-pick").addEventListener("change", () => useCsv($("run-pick").value));
  $("fit").addEventListener("click", () => fit());
  $("diagnose").addEventListener("click", () => diagnose());
  $("cancel-job").addEventListener("click", cancelJob);
  $("ps-file").addEventListener("change", onParamSetChosen);
  $("fmi-version").addEventListener("change", fmuLinks);
  for (const id of ["dl-fmu-inv", "dl-fmu-fwd"]) $(id).addEventListener("click", downloadFmu);
  $("teacher-push").addEventListener("click", teacherPush);
  const digiStep = (d) => { stopPlay(); showState(Number($("digi-step").value) + d).catch((e) => setMsg("model-msg", e.message)); };
  $("digi-prev").addEventListener("click", () => digiStep(-1));
  $("digi-next").addEventListener("click", () => digiStep(1));
  $("digi-step").addEventListener("input", () => digiStep(0));
  $("digi-play").addEventListener("click", togglePlay);
  $("teacher-push-mine").addEventListener("click", teacherPush);
  $("teacher-refresh").addEventListener("click", teacherRefresh);
  document.querySelectorAll("#tabs button").forEach((b) => b.addEventListener("click", () => selectFigure(b.dataset.fig)));
  $("view-help").textContent = VIEW_HELP[state.fig];
  addTips();
  new MutationObserver(() => addTips(document.querySelector("aside"))).observe(
    document.querySelector("aside"), { childList: true, subtree: true });
  const saved = localStorage.getItem("hyst-session");
  try {
    await openSession(saved);
  } catch (e) {
    if (saved && e.status === 404) {
      const note = $("live-note");
      note.textContent = `Your previous session "${saved}" is not on this server (the code is mistyped or the session expired): a new session was started. To rejoin another session, type its code in the Join box.`;
      note.hidden = false;
    }
    await openSession(null);
  }
}

main()
  .then(() => new Promise((r) => requestAnimationFrame(() => setTimeout(r, 0))))
  .then(loadPlotly)
  .then(() => state.shown && render($("figure"), state.shown))
  .catch((e) => setMsg("model-msg", `Start-up failed: ${e.message}`));
