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
  // a lesson's step: the figure of the view it shows is asked for with the session (the
  // server changed the session before it sent the event), one round trip instead of two
  const pending = info.lesson ? figureRequest(info.edit ? state.fig : info.lesson.view) : null;
  if (pending) pending.catch(() => {});  // its error is shown where it is drawn
  const s = await api("GET", `/api/sessions/${encodeURIComponent(state.code)}`);
  applyConfig(s.config, s.version);
  // a change of ours still in flight was based on the old model: send the pushed one
  if (state.busy) state.dirty = true;
  if (info.lesson) {
    // lesson.js shows the step, says so and draws its view, in this same task. Drawing
    // here first would redraw the old step's view with the new model, and a redraw makes
    // lesson.js compare the new model with the old step: "You are exploring".
    tell("hyst:push", { ...info, pending });
    return;
  }
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
