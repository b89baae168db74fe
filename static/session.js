// ---------------------------------------------------------------- session
import { api } from "/client.js";
import { diagnose } from "/diagnosis.js";
import { $, setMsg } from "/dom.js";
import { fmuLinks } from "/exports.js";
import { fit } from "/fitting.js";
import { applyConfig } from "/model.js";
import { state } from "/store.js";
import { draw, figureRequest } from "/view.js";

export async function openSession(code, { create = false } = {}) {
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


// Live events: a teacher push reloads the session; the note says what happened.
export function listen() {
  if (state.events) state.events.close();
  if (!window.EventSource) return;
  const name = ($("my-name").value || "").trim();
  const q = name ? `?name=${encodeURIComponent(name)}` : "";
  const es = new EventSource(`/api/sessions/${encodeURIComponent(state.code)}/events${q}`);
  es.addEventListener("push", (ev) => {
    let info = {};
    try { info = JSON.parse(ev.data); } catch { /* keep the defaults */ }
    onPushed(info).catch((e) => setMsg("model-msg", e.message));
  });
  es.addEventListener("lesson", (ev) => tell("hyst:lesson", JSON.parse(ev.data)));
  state.events = es;
}

async function onPushed(info) {
  if (info.lesson) return onStep(info);
  const s = await api("GET", `/api/sessions/${encodeURIComponent(state.code)}`);
  applyConfig(s.config, s.version);
  // a change of ours still in flight was based on the old model: send the pushed one
  if (state.busy) state.dirty = true;
  const p = state.presets.find((x) => x.name === info.preset);
  const what = p ? p.title : info.title || info.preset || (info.model === false ? "a new input" : "a model");
  const note = $("live-note");
  note.classList.remove("error");
  const input = info.signal ? " with its input" : "";
  const at = new Date().toLocaleTimeString();
  note.textContent = state.teaching
    ? `You pushed ${what}${input} to the class at ${at}.`
    : `Your teacher pushed ${what}${input} at ${at}. Your sliders now start from it.`;
  note.hidden = false;
  await draw();
  tell("hyst:push", info);
}


// A lesson's step (or the teacher's push of an edited step): the server changed this
// session to the step's model, input and mismatch before it sent the event, so the step
// is shown at once from the event (its texts, the sliders), the figure of its view is
// asked for in the same moment and drawn when it comes, and the session itself (its
// version, the rest of its config) is read beside them: "the step arrived" waits on
// neither the session's round trip nor the figure's (issue 33, a class of thirty).
async function onStep(info) {
  const step = info.lesson;
  const pending = figureRequest(info.edit ? state.fig : step.view);
  pending.catch(() => {});  // its error is shown where it is drawn
  const session = api("GET", `/api/sessions/${encodeURIComponent(state.code)}`);
  session.catch(() => {});
  if (state.config) {
    applyConfig({ ...state.config, model: step.model, signal: step.input,
      mismatch: step.mismatch ?? state.config.mismatch, use_recording: false });
  }
  // lesson.js shows the step, says so and draws its view, in this same task
  tell("hyst:push", { ...info, pending });
  const s = await session;
  if (JSON.stringify(s.config) !== JSON.stringify(state.config)) applyConfig(s.config, s.version);
  else state.version = s.version;
  if (state.busy) state.dirty = true;
}


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

// The lesson mode (static/lesson.js) hears the live events as window events ("hyst:push"
// after a push is shown, or at once for a lesson's step; "hyst:lesson").
function tell(name, detail) { window.dispatchEvent(new CustomEvent(name, { detail })); }
