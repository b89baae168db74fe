// ---------------------------------------------------------------- data
import { api, plain } from "/client.js";
import { $, el, setMsg } from "/dom.js";
import { onControlChange } from "/model.js";
import { state } from "/store.js";

let csvText = null, csvName = "upload.csv";

// What a file that is not CSV text starts with (its first bytes), in words.
const MAGIC = [
  [[0x89, 0x50, 0x4e, 0x47], "a PNG image"], [[0xff, 0xd8, 0xff], "a JPEG image"],
  [[0x47, 0x49, 0x46, 0x38], "a GIF image"], [[0x25, 0x50, 0x44, 0x46], "a PDF document"],
  [[0x50, 0x4b, 0x03, 0x04], "a ZIP archive or an Excel .xlsx workbook"],
  [[0xd0, 0xcf, 0x11, 0xe0], "an old Excel .xls or Word file"],
];

function notText(head) {
  for (const [magic, what] of MAGIC) if (magic.every((b, i) => head[i] === b)) return what;
  const utf16 = (head[0] === 0xff && head[1] === 0xfe) || (head[0] === 0xfe && head[1] === 0xff);
  return !utf16 && head.includes(0) ? "a binary file, not text" : null;
}

const size = (n) => (n >= 1e6 ? `${(n / 1e6).toFixed(1)} MB` : `${Math.ceil(n / 1e3)} kB`);
// The file's size in words, finer where it reads the same as the limit ("5.03 MB, more
// than the 5.0 MB", not "5.0 MB, more than the 5.0 MB"); app/services/analysis/upload_check.py
// says the same for viser.
const over = (n, limit) => {
  if (size(n) !== size(limit)) return size(n);
  return n >= 1e6 ? `${(n / 1e6).toFixed(2)} MB` : `${n.toLocaleString("en-US")} bytes`;
};

// The file is checked here before it is sent: its size first (a 50 MB file is not sent
// to be refused), then its first bytes (an image or a workbook is not a CSV text file).
async function refused(file) {
  const limit = state.caps && state.caps.limits && state.caps.limits.max_upload_bytes;
  if (limit && file.size > limit) {
    return `${file.name} is ${over(file.size, limit)}, more than the ${size(limit)} this explorer ` +
      "takes. Upload a shorter stretch of the recording (fewer rows) or only the time, input and output columns.";
  }
  const what = notText(new Uint8Array(await file.slice(0, 4096).arrayBuffer()));
  if (what) {
    return `${file.name} is not a CSV text file: it looks like ${what}. Save the measurement as ` +
      "CSV (comma-separated text, one row per sample, e.g. \"Save as: CSV\" in a spreadsheet) and upload that file.";
  }
  return null;
}

export async function onCsvChosen(ev) {
  const file = ev.target.files[0];
  if (!file) return;
  const why = await refused(file);
  if (why) {
    $("mapping").hidden = true;
    csvText = null;
    ev.target.value = "";
    setMsg("csv-msg", why);
    return;
  }
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
    showRuns(r.runs || [], r.run);  // the server says what it kept (by default every run)
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
    new Option(`all ${runs.length} runs, each its own loop (fitted together, as hyst fit does)`, "each"),
    new Option(`all ${runs.length} runs as one recording`, "all"));
  pick.value = kept === null || kept === undefined ? String(runs[0]) : String(kept);
}
