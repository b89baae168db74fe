// Downloads (parameter set, .mat, C, FMU) and loading a saved parameter set.

import { api, detailText, plain, STATUS_TEXT } from "/client.js";
import { $, el, setMsg } from "/dom.js";
import { applyConfig } from "/model.js";
import { state } from "/store.js";
import { draw } from "/view.js";

// The FMU downloads follow the FMI version chosen (the server compiles them on demand).
export function fmuLinks() {
  const base = `/api/sessions/${encodeURIComponent(state.code)}/export/fmu?fmi=${$("fmi-version").value}`;
  $("dl-fmu-inv").href = `${base}&inverse=true`;
  $("dl-fmu-fwd").href = `${base}&inverse=false`;
}

// An FMU is compiled on the server (a second or so) and may be refused (a model without an
// inverse, a busy server): fetch it, and say why when there is no file.
export async function downloadFmu(ev) {
  ev.preventDefault();
  const link = ev.currentTarget;
  setMsg("export-msg", "building the FMU…");
  let r;
  try {
    r = await fetch(link.href);
  } catch {
    setMsg("export-msg", "The explorer server cannot be reached: is it still running?");
    return;
  }
  if (!r.ok) {
    let detail = "";
    try { detail = detailText((await r.json()).detail); } catch { /* not JSON */ }
    setMsg("export-msg", `No FMU: ${detail && r.status < 500 ? plain(detail) : STATUS_TEXT[r.status] || `error ${r.status}`}`);
    return;
  }
  const blob = await r.blob();
  const m = /filename="?([^";]+)"?/.exec(r.headers.get("Content-Disposition") || "");
  const name = m ? m[1] : "hysteresis.fmu";
  const a = el("a", { href: URL.createObjectURL(blob), download: name });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  setMsg("export-msg", `Downloaded ${name} (${blob.size} bytes)`, true);
}

export async function onParamSetChosen(ev) {
  const file = ev.target.files[0];
  if (!file) return;
  try {
    // the file's text is the body as it is (a saved parameter set or a bare model)
    const s = await api("PUT", `/api/sessions/${state.code}/parameter-set`, await file.text());
    applyConfig(s.config, s.version);
    await draw();
    setMsg("export-msg", `Loaded ${file.name}`, true);
  } catch (e) {
    setMsg("export-msg", `Not loaded: ${e.message}`);
  } finally {
    ev.target.value = "";
  }
}
