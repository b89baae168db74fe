// ---------------------------------------------------------------- data
import { api, plain } from "/client.js";
import { $, el, setMsg } from "/dom.js";
import { onControlChange } from "/model.js";
import { state } from "/store.js";

let csvText = null, csvName = "upload.csv";

export async function onCsvChosen(ev) {
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
export async function useCsv(run) {
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

export function showTiming(uneven) {
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
