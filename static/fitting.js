// Fitting a model to the uploaded recording (a job), and its overlay view.

import { api } from "/client.js";
import { $, el } from "/dom.js";
import { jobFailed, runJob } from "/jobs.js";
import { applyConfig } from "/model.js";
import { showFitted } from "/presets.js";
import { state } from "/store.js";
import { selectFigure } from "/view.js";

export async function fit(running = null) {
  // an empty operator count: chosen by cross-validation, as hyst fit chooses it
  const n = $("fit-n").value.trim() === "" ? null : Number($("fit-n").value);
  const params = { n, kind: $("fit-kind").value };
  try {
    const r = await runJob("fit", params, `/api/sessions/${state.code}/fit`, params, running);
    if (!r) return;
    state.fitFigure = r.figure;
    const rep = r.report;
    // the fit in the page's words: the model (and how it was chosen), the held-out error
    // (the number hyst fit reports), how each recording starts, the warnings (e.g. a
    // held-out error far above the noise floor, and where)
    const w = rep.words || {};
    const unit = rep.output_unit ? ` ${rep.output_unit}` : "";
    const para = (cls, text) => el("p", { className: cls, textContent: text });
    const more = (title, text) => el("details", {}, el("summary", { textContent: title }),
      para("help", text));
    $("report").replaceChildren(
      para("msg ok", `Fit: ${w.model || rep.kind}. ${w.heldout || ""}`.trim()),
      para("help", `On every row: RMS error ${rep.rms_error.toPrecision(4)}${unit}, ` +
        `${rep.nrmse_percent.toPrecision(3)} % of the output range.`),
      ...(w.memory ? [para("help", `Start: ${w.memory}.`)] : []),
      ...(w.warnings || rep.warnings || []).map((t) => para("msg rule", `Warning: ${t}`)),
      ...(w.choice ? [more("How the model was chosen", `${w.choice}.`)] : []));
    const s = await api("GET", `/api/sessions/${state.code}`);
    applyConfig(s.config, s.version);
    showFitted();
    selectFigure("fit");
  } catch (e) {
    $("report").replaceChildren();
    jobFailed("Fit", e);
  }
}
