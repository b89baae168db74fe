// Long work (fit, diagnosis) as a server job: progress, cancel, what a failure says.

import { api, ApiError, plain } from "/client.js";
import { $, setMsg } from "/dom.js";
import { state } from "/store.js";

// Long work (fit, diagnosis): one at a time, the buttons are disabled and a note counts
// the seconds. A server with the jobs API runs it as a job (progress, cancel); an older
// one answers the plain endpoint. ``running`` is a job already queued or running (found
// by resumeJob after a reload): it is followed instead of starting a new one.
export async function runJob(kind, params, syncPath, syncBody, running = null) {
  if (state.job) return null;
  const buttons = [$("fit"), $("diagnose")];
  buttons.forEach((b) => { b.disabled = true; });
  // a new run replaces what the last one said (a "cancelled" or "failed" line)
  if (state.jobSaid) { setMsg("csv-msg", ""); state.jobSaid = false; }
  const busy = $("busy"), bar = $("job-progress"), cancel = $("cancel-job");
  const t0 = performance.now();
  const label = (kind === "fit" ? "Fitting" : "Diagnosing") +
    (running ? " (started before this page was loaded)" : "");
  let progress = null, message = "", left = "";
  const tick = () => {
    const s = ((performance.now() - t0) / 1000).toFixed(0);
    const pct = progress === null ? "" : `${Math.round(100 * progress)} %, `;
    busy.textContent = `${label}… working, ${pct}${s} s${left ? `, ${left}` : ""}` +
      (message ? ` (${message})` : "");
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
      left = job.time_left ? plain(job.time_left) : "";
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


// The job stops at its next progress report; runJob's polling sees it end "cancelled".
export async function cancelJob() {
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
export function jobFailed(what, e) {
  state.jobSaid = true;
  if (e instanceof JobCancelled) {
    setMsg("csv-msg", `${what} cancelled: nothing was changed.`, true);
  } else {
    setMsg("csv-msg", `${what} failed: ${e.message}`);
  }
}
