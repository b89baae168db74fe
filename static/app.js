// Hysteresis Explorer web page: talks to the REST API, draws figures with Plotly.react.
// Latest value wins: while a request is in flight, further changes only mark the state
// dirty, and one follow-up request carries the newest values.
// Every string from the server or a file is put in the page as text (textContent,
// new Option), never as markup; the page needs no inline script or style (CSP
// "default-src 'self'").
//
// This module starts the page: it wires the controls to the modules that hold the work
// (ES modules, each imported by path from the server's static folder):
//   store.js     the page's state (the one owner; imported, never a global)
//   dom.js       $, el, setMsg, number boxes    client.js  the REST client and its messages
//   plots.js     drawing (quickplot, plotly, phone and projector layouts)
//   view.js      the figure on show, the view tabs  digitized.js  the digitized step / play
//   model.js     model sliders, signal controls, the JSON box, the slider pump, presets
//   presets.js   the preset dropdown                session.js  open / join, live events, resume
//   upload.js    CSV preview, column mapping, uneven time stamps, runs
//   jobs.js      fit / diagnosis as jobs            fitting.js, diagnosis.js  their results
//   exports.js   downloads and saved parameter sets classroom.js  the teacher's panel
//   tips.js      every control's tooltip            lesson.js  the lesson mode (its own entry)

import { teacherPush, teacherRefresh } from "/classroom.js";
import { api } from "/client.js";
import { diagnose } from "/diagnosis.js";
import { showState, stopPlay, togglePlay } from "/digitized.js";
import { $, numberTyped, setMsg, showOutput } from "/dom.js";
import { downloadFmu, fmuLinks, onParamSetChosen } from "/exports.js";
import { fit } from "/fitting.js";
import { cancelJob } from "/jobs.js";
import {
  applyModelJson, initControls, loadPreset, onControlChange, onOperatorCount,
} from "/model.js";
import { render, setProjector } from "/plots.js";
import { showPresetDesc } from "/presets.js";
import { listen, openSession } from "/session.js";
import { state } from "/store.js";
import { addTips } from "/tips.js";
import { onCsvChosen, showTiming, useCsv } from "/upload.js";
import { selectFigure, VIEW_HELP } from "/view.js";

// plotly.js is loaded after the first figure is on screen (quickplot.js draws it);
// from then on every figure is drawn by plotly
let plotlyLoading = null;
function loadPlotly() {
  plotlyLoading ??= new Promise((resolve, reject) => {
    const s = Object.assign(document.createElement("script"), { src: "/vendor/plotly.min.js" });
    s.addEventListener("load", resolve);
    s.addEventListener("error", () => reject(new Error("the plotting library did not load")));
    document.head.append(s);
  });
  return plotlyLoading;
}

// ---------------------------------------------------------------- start
async function main() {
  initControls($("model-controls"));
  const [caps, presets, v] = await Promise.all([
    api("GET", "/api/capabilities"), api("GET", "/api/presets"), api("GET", "/api/viser-url")]);
  state.caps = caps;
  state.presets = presets;
  $("kind").replaceChildren(...caps.signals.map((s) => new Option(s.replace(/_/g, " "), s)));
  for (const id of ["preset", "teacher-preset"]) {
    $(id).replaceChildren(...presets.map((p) => new Option(p.title, p.name)));
  }
  showPresetDesc();
  const kindTitle = caps.fit_kind_titles || {};  // the registry's words, not its names
  $("fit-kind").replaceChildren(...caps.fit_kinds.map((k) => new Option(kindTitle[k] || k, k)),
    new Option("Automatic choice (the model hyst fit chooses)", "auto"));
  $("samples").max = caps.limits.max_samples;
  $("n").max = caps.limits.max_operators;
  $("fit-n").max = caps.limits.max_operators;
  if (v.enabled) {
    const link = $("viser-link");
    link.href = `${location.protocol}//${location.hostname}:${v.port}/`;
    link.hidden = false;
  }
  for (const id of ["amplitude", "frequency", "offset", "duration", "mismatch"]) {
    $(id).addEventListener("input", () => { showOutput($(id)); onControlChange(); });
    $(`${id}-num`).addEventListener("change", () =>
      numberTyped(id, onControlChange, (note) => setMsg("model-msg", note)));
  }
  for (const id of ["kind", "samples", "use-recording"]) $(id).addEventListener("change", onControlChange);
  $("n").addEventListener("change", onOperatorCount);
  $("preset").addEventListener("change", () => { state.presetChanged = false; showPresetDesc(); });
  $("load-preset").addEventListener("click", loadPreset);
  // what Join did is said under the header too, where a phone shows it (the Model
  // section's message is screens below the plot there)
  const joined = (text, ok) => {
    setMsg("model-msg", text, ok);
    const note = $("live-note");
    note.textContent = text;
    note.classList.toggle("error", !ok);
    note.hidden = false;
  };
  const join = async () => {
    const code = $("join-code").value.trim();
    if (!code) { joined("Type the session code first.", false); return; }
    $("join").disabled = true;
    const note = $("live-note");
    note.classList.remove("error");
    note.textContent = `Joining session ${code} …`;
    note.hidden = false;
    try {
      await openSession(code);
      joined(`Joined session ${code}.`, true);
    } catch (e) {
      joined(e.status === 404 || e.status === 422
        ? `No session "${code}" on this server: the code may be mistyped (it looks like abcd-efgh-jkmn-pqrs and is shown at the top of the page that uses it) or the session has expired. You are still in session ${state.code}.`
        : e.message, false);
    } finally {
      $("join").disabled = false;
    }
  };
  $("join").addEventListener("click", join);
  $("my-name").value = localStorage.getItem("hyst-name") || "";
  $("projector").addEventListener("click", () => setProjector(!document.body.classList.contains("projector")));
  if (localStorage.getItem("hyst-projector")) setProjector(true);
  $("my-name").addEventListener("change", () => {
    localStorage.setItem("hyst-name", $("my-name").value.trim());
    if (state.code) listen();  // the teacher's list shows the new name
  });
  $("join-code").addEventListener("keydown", (e) => { if (e.key === "Enter") join(); });
  $("new-session").addEventListener("click", () => openSession(null).catch((e) => setMsg("model-msg", e.message)));
  $("apply-json").addEventListener("click", applyModelJson);
  $("csv-file").addEventListener("change", onCsvChosen);
  // the header's Upload CSV: the same file chooser, without scrolling the side panel to
  // its Data section (below the fold at 1920x1080); once a file is chosen the section
  // (its mapping, or why the file was refused) is scrolled to the top of the side panel,
  // the page itself (header, plot) left where it is
  $("upload-open").addEventListener("click", () => {
    const input = $("csv-file");
    input.addEventListener("change", () => {
      const aside = input.closest("aside"), section = input.closest("section");
      const scrolls = aside && aside.scrollHeight > aside.clientHeight
        && /auto|scroll/.test(getComputedStyle(aside).overflowY);
      if (scrolls) aside.scrollTop += section.getBoundingClientRect().top - aside.getBoundingClientRect().top;
      else section.scrollIntoView({ block: "start" });  // a phone: the page scrolls
    }, { once: true });
    input.click();
  });
  $("use-csv").addEventListener("click", () => useCsv());
  $("t-col").addEventListener("change", () => showTiming(null));  // asked again if uneven
  $("run-pick").addEventListener("change", () => useCsv($("run-pick").value));
  $("fit").addEventListener("click", () => fit());
  $("diagnose").addEventListener("click", () => diagnose());
  $("cancel-job").addEventListener("click", cancelJob);
  $("ps-file").addEventListener("change", onParamSetChosen);
  $("fmi-version").addEventListener("change", fmuLinks);
  for (const id of ["dl-fmu-inv", "dl-fmu-fwd"]) $(id).addEventListener("click", downloadFmu);
  $("teacher-push").addEventListener("click", teacherPush);
  const digiStep = (d) => { stopPlay(); showState(Number($("digi-step").value) + d).catch((e) => setMsg("model-msg", e.message)); };
  $("digi-prev").addEventListener("click", () => digiStep(-1));
  $("digi-next").addEventListener("click", () => digiStep(1));
  $("digi-step").addEventListener("input", () => digiStep(0));
  $("digi-play").addEventListener("click", togglePlay);
  $("teacher-push-mine").addEventListener("click", teacherPush);
  $("teacher-refresh").addEventListener("click", teacherRefresh);
  document.querySelectorAll("#tabs button").forEach((b) => b.addEventListener("click", () => selectFigure(b.dataset.fig)));
  $("view-help").textContent = VIEW_HELP[state.fig];
  addTips();
  new MutationObserver(() => addTips(document.querySelector("aside"))).observe(
    document.querySelector("aside"), { childList: true, subtree: true });
  const saved = localStorage.getItem("hyst-session");
  try {
    await openSession(saved);
  } catch (e) {
    if (saved && e.status === 404) {
      const note = $("live-note");
      note.textContent = `Your previous session "${saved}" is not on this server (the code is mistyped or the session expired): a new session was started. To rejoin another session, type its code in the Join box.`;
      note.hidden = false;
    }
    await openSession(null);
  }
}

main()
  .then(() => new Promise((r) => requestAnimationFrame(() => setTimeout(r, 0))))
  .then(loadPlotly)
  .then(() => state.shown && render($("figure"), state.shown))
  .catch((e) => setMsg("model-msg", `Start-up failed: ${e.message}`));
