// ---------------------------------------------------------------- teacher
import { api } from "/client.js";
import { $, setMsg } from "/dom.js";
import { readConfig } from "/model.js";
import { state } from "/store.js";

export async function teacherPush(ev) {
  state.token = $("teacher-token").value;
  try {
    const mode = $("teacher-input").value;
    const mine = ev && ev.target && ev.target.id === "teacher-push-mine";
    const body = mine ? { model: readConfig().model }
      : { preset: $("teacher-preset").value, use_preset_input: mode === "preset" };
    if (mode === "mine") body.signal = readConfig().signal;
    state.teaching = true;  // this page's own push is not "your teacher pushed"
    const r = await api("POST", "/api/teacher/push", body);
    setMsg("teacher-msg", r.text || `Pushed to ${r.sessions} sessions (${r.pages} open pages).`, true);
  } catch (e) {
    if (e.status === 403) state.teaching = false;
    setMsg("teacher-msg", e.status === 403 ? "Wrong teacher token." : `Not pushed: ${e.message}`);
  }
}

export async function teacherRefresh() {
  state.token = $("teacher-token").value;
  try {
    const r = await api("GET", "/api/teacher/connected");
    // counts and names only: a projected panel must not show the session codes
    setMsg("teacher-msg", r.text || `Connected: ${r.pages} open pages in ${r.sessions_live} of ${r.sessions} sessions.`, true);
  } catch (e) {
    setMsg("teacher-msg", e.status === 403 ? "Wrong teacher token." : e.message);
  }
}
