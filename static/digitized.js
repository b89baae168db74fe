// ---------------------------------------------------------------- digitized step / play
import { api } from "/client.js";
import { $, setMsg, showOutput } from "/dom.js";
import { render } from "/plots.js";
import { state } from "/store.js";

// The digitized view at one state of its trace: the server draws it (?state=k); Play
// steps through the trace at 2 states per second.
const DIGI_PLAY_MS = 500;

export function showDigiControls(res) {
  const n = state.fig === "digitized" ? res.digitized_states : undefined;
  $("digi-controls").hidden = !n;
  if (!n) { stopPlay(); state.digiStep = null; return; }
  const step = $("digi-step");
  step.max = String(n - 1);
  if (state.digiTimer) { showOutput(step); return; }
  // the view opens at the first state (so that "step forward" steps), and keeps the state
  // the user stepped to when the model changes; the figure drawn shows the final state
  const k = Math.min(state.digiStep ?? 0, n - 1);
  step.value = String(k);
  showOutput(step);
  if (k === n - 1) document.body.dataset.digiState = String(k);
  else showState(k).catch((e) => setMsg("model-msg", e.message));
}

export async function showState(k) {
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

export function stopPlay() {
  clearInterval(state.digiTimer);
  state.digiTimer = null;
  $("digi-play").textContent = "Play from the start";
}

export function togglePlay() {
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
