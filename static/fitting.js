// Fitting a model to the uploaded recording (a job), and its overlay view.

import { api } from "/client.js";
import { $, el } from "/dom.js";
import { jobFailed, runJob } from "/jobs.js";
import { applyConfig } from "/model.js";
import { showFitted } from "/presets.js";
import { state } from "/store.js";
import { selectFigure } from "/view.js";

export async function fit(running = null) {
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
      textContent: `Fit: RMS error ${rep.rms_error.toPrecision(4)}${rep.output_unit ? ` ${rep.output_unit}` : ""}, ` +
        `${rep.nrmse_percent.toPrecision(3)} % of the output range`,
    }), ...warned);
    const s = await api("GET", `/api/sessions/${state.code}`);
    applyConfig(s.config, s.version);
    showFitted();
    selectFigure("fit");
  } catch (e) {
    $("report").replaceChildren();
    jobFailed("Fit", e);
  }
}
