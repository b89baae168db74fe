// The session's model and input on the page: the model's sliders (static/controls.js), the
// signal controls and the JSON box, sent to the server one request at a time.

import { api } from "/client.js";
import { ModelControls } from "/controls.js";
import { $, setMsg, showOutput, sliderValue } from "/dom.js";
import { syncPreset } from "/presets.js";
import { state } from "/store.js";
import { draw, RESULT_VIEWS } from "/view.js";

// The model's sliders come from the server's description of the model (static/controls.js);
// the JSON box follows them, so Apply never undoes a slider.
let controls = null;

// The sliders of the session's model, built in `container` (once, at start-up).
export function initControls(container) {
  controls = new ModelControls(container, { api, onChange: onSliderMoved });
}

function showModelJson(model) {
  const box = $("model-json");
  if (document.activeElement !== box) box.value = JSON.stringify(model, null, 1);
}

// What a slider's rule changed (r3 stopped just below r4) stays on show until the next move.
export function showNote(note) {
  state.note = note;
  setMsg("model-msg", note);
  $("model-msg").classList.toggle("rule", Boolean(note));
}

function onSliderMoved(note) {
  showModelJson(controls.model);
  showNote(note);
  onControlChange();
}

export function applyConfig(cfg, version, { fresh = false } = {}) {
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
  document.querySelectorAll("aside input[type=range]").forEach((r) => showOutput(r));
  // the number boxes hold the exact values (a slider snaps to its step)
  for (const k of ["amplitude", "frequency", "offset", "duration"]) showOutput($(k), cfg.signal[k]);
  showOutput($("mismatch"), cfg.mismatch);
  syncPreset(m, { fresh });
}

export function readConfig() {
  const cfg = structuredClone(state.config);
  if (controls.model) cfg.model = structuredClone(controls.model);
  for (const k of ["amplitude", "frequency", "offset", "duration"]) cfg.signal[k] = sliderValue(k);
  cfg.signal.kind = $("kind").value;
  cfg.signal.samples = Number($("samples").value);
  cfg.mismatch = sliderValue("mismatch");
  cfg.use_recording = $("use-recording").checked;
  return cfg;
}

export function onControlChange() {
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

export async function loadPreset() {
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

// "operators n" changed: the thresholds are spread evenly up to the widest, the total weight
// shared; a count outside 1..the server's limit is set to the nearest allowed (and said).
export function onOperatorCount() {
  const max = state.caps.limits.max_operators;
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
}

// The JSON box's Apply: any model type, typed by hand.
export async function applyModelJson() {
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
}
