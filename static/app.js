// Hysteresis Explorer web page: talks to the REST API, draws figures with Plotly.react.
// Latest value wins: while a request is in flight, further changes only mark the state
// dirty, and one follow-up request carries the newest values.

const $ = (id) => document.getElementById(id);
const state = { code: null, config: null, fig: "loop", fitFigure: null, busy: false, dirty: false };

async function api(method, path, body, type = "application/json") {
  const opts = { method, headers: {} };
  if (body !== undefined) {
    opts.headers["Content-Type"] = type;
    opts.body = type === "application/json" ? JSON.stringify(body) : body;
  }
  const r = await fetch(path, opts);
  const text = await r.text();
  let data = null;
  try { data = text ? JSON.parse(text) : null; } catch { data = text; }
  if (!r.ok) {
    const d = data && data.detail !== undefined ? data.detail : data;
    const msg = typeof d === "string" ? d : (d && d.message) ? d.message : JSON.stringify(d);
    const err = new Error(msg);
    err.status = r.status;
    throw err;
  }
  return data;
}

function setMsg(id, text, ok = false) {
  const el = $(id);
  el.textContent = text || "";
  el.classList.toggle("ok", ok);
}

function showOutput(input) {
  const out = document.querySelector(`output[for="${input.id}"]`);
  if (out) out.textContent = Number(input.value).toFixed(3).replace(/\.?0+$/, "");
}

// ---------------------------------------------------------------- controls <-> config
function buildOperatorSliders(model) {
  const rDiv = $("thresholds"), wDiv = $("weights");
  rDiv.replaceChildren(); wDiv.replaceChildren();
  const n = model.thresholds.length;
  if (n > 25) {
    wDiv.textContent = `${n} operators: edit them through the API or the viser GUI.`;
    return;
  }
  const rmax = Math.max(10, 2 * Math.max(...model.thresholds));
  model.thresholds.forEach((r, i) => rDiv.append(slider(`r${i + 1}`, 0.001, rmax, 0.001, r, "r")));
  model.weights.forEach((w, i) => wDiv.append(slider(`p${i + 1}`, -1.5, 2, 0.001, w, "p")));
}

function slider(name, min, max, step, value, group) {
  const label = document.createElement("label");
  label.textContent = name + " ";
  const input = Object.assign(document.createElement("input"),
    { type: "range", min, max, step, value, id: `${group}-${name}` });
  input.dataset.group = group;
  input.setAttribute("aria-label", name);
  const out = document.createElement("output");
  out.htmlFor = input.id;
  label.append(input, out);
  input.addEventListener("input", () => { showOutput(input); onControlChange(); });
  queueMicrotask(() => showOutput(input));
  return label;
}

function applyConfig(cfg) {
  state.config = cfg;
  const m = cfg.model;
  const isPI = m.type === "pi";
  $("pi-controls").hidden = !isPI;
  if (isPI) {
    $("p0").value = m.p0;
    $("n").value = m.thresholds.length;
    buildOperatorSliders(m);
  }
  for (const k of ["amplitude", "frequency", "offset", "duration"]) $(k).value = cfg.signal[k];
  $("kind").value = cfg.signal.kind;
  $("samples").value = cfg.signal.samples;
  $("mismatch").value = cfg.mismatch;
  $("model-json").value = JSON.stringify(m, null, 1);
  if (!isPI) $("json-edit").open = true;
  $("use-recording").checked = cfg.use_recording;
  document.querySelectorAll("aside input[type=range]").forEach(showOutput);
}

function readConfig() {
  const cfg = structuredClone(state.config);
  if (cfg.model.type === "pi") {
    cfg.model.p0 = Number($("p0").value);
    const rs = [...document.querySelectorAll('input[data-group="r"]')].map((e) => Number(e.value));
    const ws = [...document.querySelectorAll('input[data-group="p"]')].map((e) => Number(e.value));
    if (rs.length) { cfg.model.thresholds = rs; cfg.model.weights = ws; }
  }
  for (const k of ["amplitude", "frequency", "offset", "duration"]) cfg.signal[k] = Number($(k).value);
  cfg.signal.kind = $("kind").value;
  cfg.signal.samples = Number($("samples").value);
  cfg.mismatch = Number($("mismatch").value);
  cfg.use_recording = $("use-recording").checked;
  return cfg;
}

function onControlChange() {
  state.dirty = true;
  pump();
}

// One request at a time; the newest control values win.
async function pump() {
  if (state.busy) return;
  state.busy = true;
  try {
    while (state.dirty) {
      state.dirty = false;
      const cfg = readConfig();
      try {
        const s = await api("PATCH", `/api/sessions/${state.code}/config`, cfg);
        state.config = s.config;
        setMsg("model-msg", "");
      } catch (e) {
        setMsg("model-msg", `Not applied: ${e.message}`);
        continue;
      }
      await draw();
    }
  } finally {
    state.busy = false;
  }
}

async function draw() {
  const el = $("figure");
  const name = state.fig === "fit" ? "loading" : state.fig;
  const res = await api("GET", `/api/sessions/${state.code}/figures?name=${name}`);
  let f = res.figures[name];
  if (state.fig === "fit") {
    f = state.fitFigure || { data: [], layout: { title: { text: "Fit a model to see the overlay" } } };
  }
  await Plotly.react(el, f.data, f.layout, { responsive: true, displaylogo: false });
  const parts = [`${res.model_type}`, `n = ${res.n_operators ?? "?"}`];
  if (res.max_loop_width !== undefined) parts.push(`σ = ${res.max_loop_width.toFixed(4)}`);
  if (res.slopes) parts.push(`slopes ${res.slopes.map((s) => s.toFixed(3)).join(", ")}`);
  if (res.inverse_error) parts.push(`⚠ ${res.inverse_error}`);
  else if (res.invertible === false) parts.push("⚠ not invertible (a slope ≤ 0)");
  $("status").textContent = parts.join(" · ") + ` · ${res.elapsed_ms.toFixed(1)} ms`;
  document.body.dataset.fig = state.fig;
  document.body.dataset.ready = String(res.version);
}

// ---------------------------------------------------------------- session
async function openSession(code) {
  const s = code ? await api("PUT", `/api/sessions/${encodeURIComponent(code)}`)
                 : await api("POST", "/api/sessions");
  state.code = s.code;
  localStorage.setItem("hyst-session", s.code);
  $("code").textContent = s.code;
  for (const f of ["json", "mat", "c"]) $(`dl-${f}`).href = `/api/sessions/${s.code}/export/${f}`;
  applyConfig(s.config);
  await draw();
}

// ---------------------------------------------------------------- data
let csvText = null, csvName = "upload.csv";

async function onCsvChosen(ev) {
  const file = ev.target.files[0];
  if (!file) return;
  csvText = await file.text();
  csvName = file.name;
  try {
    const p = await api("POST", "/api/csv/preview", csvText, "text/csv");
    const head = `<tr>${p.columns.map((c) => `<th>${c}</th>`).join("")}</tr>`;
    const rows = p.rows.map((r) => `<tr>${r.map((v) => `<td>${v}</td>`).join("")}</tr>`).join("");
    $("preview").innerHTML = head + rows;
    for (const [id, guess] of [["t-col", 0], ["u-col", 1], ["y-col", 2]]) {
      const sel = $(id);
      sel.replaceChildren(...(id === "t-col" ? [new Option("(none: 1 ms)", "")] : []),
        ...p.columns.map((c, i) => new Option(c, String(i))));
      const named = { "t-col": ["t", "time"], "u-col": ["u", "input"], "y-col": ["y", "output"] }[id];
      const idx = p.columns.findIndex((c) => named.includes(c.toLowerCase()));
      sel.value = String(idx >= 0 ? idx : Math.min(guess, p.columns.length - 1));
    }
    $("mapping").hidden = false;
    setMsg("csv-msg", `${p.n_rows} rows, ${p.columns.length} columns: check the mapping`, true);
  } catch (e) {
    $("mapping").hidden = true;
    setMsg("csv-msg", `CSV not readable: ${e.message}`);
  }
}

async function useCsv() {
  const q = new URLSearchParams({ name: csvName });
  for (const [id, key] of [["t-col", "t_col"], ["u-col", "u_col"], ["y-col", "y_col"]]) {
    if ($(id).value !== "") q.set(key, $(id).value);
  }
  try {
    const r = await api("POST", `/api/sessions/${state.code}/recording?${q}`, csvText, "text/csv");
    setMsg("csv-msg", `Loaded ${r.name}: ${r.samples} samples`, true);
    $("use-recording").checked = true;
    onControlChange();
  } catch (e) {
    setMsg("csv-msg", `CSV not loaded: ${e.message}`);
  }
}

async function fit() {
  try {
    const r = await api("POST", `/api/sessions/${state.code}/fit`,
      { n: Number($("fit-n").value), kind: $("fit-kind").value });
    state.fitFigure = r.figure;
    const rep = r.report;
    $("report").innerHTML = `<p class="msg ok">Fit: RMS error ${rep.rms_error.toPrecision(4)}, ` +
      `${rep.nrmse_percent.toPrecision(3)} % of range</p>`;
    const s = await api("GET", `/api/sessions/${state.code}`);
    applyConfig(s.config);
    selectFigure("fit");
  } catch (e) {
    $("report").innerHTML = "";
    setMsg("csv-msg", `Fit failed: ${e.message}`);
  }
}

async function diagnose() {
  try {
    const r = await api("POST", `/api/sessions/${state.code}/diagnose`);
    const items = (r.findings || []).map((f) => `<li>${typeof f === "string" ? f : JSON.stringify(f)}</li>`);
    const nums = Object.entries(r).filter(([, v]) => typeof v === "number")
      .map(([k, v]) => `<li>${k}: ${v.toPrecision(4)}</li>`);
    $("report").innerHTML = `<div id="diagnosis"><h3>Diagnosis</h3><p><em>${r.engine || ""}</em></p>` +
      `<ul>${items.join("")}${nums.join("")}</ul>` +
      (r.document ? `<a href="/api/sessions/${state.code}/diagnosis/report.html" target="_blank">full report (HTML)</a>` : "") +
      "</div>";
  } catch (e) {
    setMsg("csv-msg", `Diagnosis failed: ${e.message}`);
  }
}

async function onParamSetChosen(ev) {
  const file = ev.target.files[0];
  if (!file) return;
  try {
    const s = await api("PUT", `/api/sessions/${state.code}/parameter-set`, await file.text());
    applyConfig(s.config);
    await draw();
    setMsg("export-msg", `Loaded ${file.name}`, true);
  } catch (e) {
    setMsg("export-msg", `Not loaded: ${e.message}`);
  }
}

function selectFigure(name) {
  state.fig = name;
  document.querySelectorAll("#tabs button").forEach((b) => b.classList.toggle("active", b.dataset.fig === name));
  draw().catch((e) => setMsg("model-msg", e.message));
}

// ---------------------------------------------------------------- start
async function main() {
  const caps = await api("GET", "/api/capabilities");
  $("kind").replaceChildren(...caps.signals.map((s) => new Option(s, s)));
  $("preset").replaceChildren(...caps.presets.map((p) => new Option(p, p)));
  $("fit-kind").replaceChildren(...caps.fit_kinds.map((k) => new Option(k, k)));
  $("samples").max = caps.limits.max_samples;
  $("n").max = caps.limits.max_operators;
  const v = await api("GET", "/api/viser-url");
  if (v.enabled) {
    const link = $("viser-link");
    link.href = `${location.protocol}//${location.hostname}:${v.port}/`;
    link.hidden = false;
  }
  for (const id of ["p0", "amplitude", "frequency", "offset", "duration", "mismatch"]) {
    $(id).addEventListener("input", () => { showOutput($(id)); onControlChange(); });
  }
  for (const id of ["kind", "samples", "use-recording"]) $(id).addEventListener("change", onControlChange);
  $("n").addEventListener("change", () => {
    const n = Math.max(1, Math.min(Number($("n").value) || 1, caps.limits.max_operators));
    const m = state.config.model;
    const rmax = m.thresholds[m.thresholds.length - 1];
    const total = m.weights.reduce((a, b) => a + b, 0);
    m.thresholds = Array.from({ length: n }, (_, i) => (rmax * (i + 1)) / n);
    m.weights = Array(n).fill(total / n);
    buildOperatorSliders(m);
    onControlChange();
  });
  $("load-preset").addEventListener("click", async () => {
    const s = await api("POST", `/api/sessions/${state.code}/preset/${$("preset").value}`);
    applyConfig(s.config);
    await draw();
  });
  $("join").addEventListener("click", () => openSession($("join-code").value.trim())
    .catch((e) => setMsg("model-msg", e.message)));
  $("apply-json").addEventListener("click", async () => {
    let model;
    try { model = JSON.parse($("model-json").value); } catch (e) {
      setMsg("model-msg", `Not valid JSON: ${e.message}`);
      return;
    }
    try {
      const s = await api("PATCH", `/api/sessions/${state.code}/config`, { model });
      applyConfig(s.config);
      setMsg("model-msg", "");
      await draw();
    } catch (e) {
      setMsg("model-msg", `Not applied: ${e.message}`);
    }
  });
  $("csv-file").addEventListener("change", onCsvChosen);
  $("use-csv").addEventListener("click", useCsv);
  $("fit").addEventListener("click", fit);
  $("diagnose").addEventListener("click", diagnose);
  $("ps-file").addEventListener("change", onParamSetChosen);
  document.querySelectorAll("#tabs button").forEach((b) => b.addEventListener("click", () => selectFigure(b.dataset.fig)));
  const saved = localStorage.getItem("hyst-session");
  try {
    await openSession(saved);
  } catch {
    await openSession(null);
  }
}

main().catch((e) => setMsg("model-msg", `Start-up failed: ${e.message}`));
