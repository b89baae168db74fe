// The diagnosis of the uploaded recording (a job): its findings, the report link, and the
// before / after view.

import { $, el } from "/dom.js";
import { jobFailed, runJob } from "/jobs.js";
import { state } from "/store.js";
import { selectFigure } from "/view.js";

export async function diagnose(running = null) {
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
