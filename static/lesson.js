// Lesson mode of the web page: the class follows the teacher's lesson step by step.
// Everyone sees the class step (its prompt, what to look for) above the plot, and may
// explore and come back with "Back to the class step". The teacher (in the Teacher
// panel, with the token) starts a lesson, moves the class, ends it, loads a lesson file
// and makes a lesson from what is on screen. Every move is the teacher's push: it
// arrives through session.js's event stream ("hyst:push" with the step in info.lesson).
// Every text of a lesson is put in the page as text (textContent), never as markup.

import { api } from "/client.js";
import { $, el, setMsg, setText } from "/dom.js";
import { applyConfig } from "/model.js";
import { state } from "/store.js";
import { draw, selectFigure } from "/view.js";

const L = { step: null, choices: new Map(), draft: { title: "My lesson", steps: [] } };

// ---------------------------------------------------------------- what everyone sees
function buildBanner() {
  const box = el("section", { id: "lesson", className: "lesson", hidden: true });
  box.setAttribute("aria-live", "polite");
  box.setAttribute("aria-label", "the class's lesson");
  box.append(
    el("p", { className: "lesson-head" }, el("strong", { id: "lesson-title" }), " · ",
      el("span", { id: "lesson-where" }), ": ", el("strong", { id: "lesson-step-title" })),
    el("p", { id: "lesson-prompt", className: "lesson-prompt" }),
    el("p", { id: "lesson-look", className: "lesson-look" }, el("strong", { textContent: "Look for: " }),
      el("span", { id: "lesson-look-text" })),
    el("p", { className: "lesson-foot" },
      el("button", { id: "lesson-return", type: "button", textContent: "Back to the class step",
        title: "Give your page the class's step again (model, input, view), after you explored" }),
      " ", el("span", { id: "lesson-state", className: "help" })));
  $("plots").prepend(box);
  $("lesson-return").addEventListener("click", backToClass);
}

function show(step) {
  L.step = step && step.running ? step : null;
  const was = $("lesson").hidden;
  $("lesson").hidden = !L.step;
  if (was !== $("lesson").hidden) window.dispatchEvent(new Event("resize"));  // the plot's height
  syncTeacherButtons();
  if (!L.step) return;
  setText("lesson-title", step.title);
  setText("lesson-where", `step ${step.step} of ${step.steps}`);
  setText("lesson-step-title", step.step_title);
  setText("lesson-prompt", step.prompt);
  setText("lesson-look-text", step.look_for || "");
  $("lesson-look").hidden = !step.look_for;
  markExploring();
}

// A page is on the class step while its model, input and mismatch are the step's.
function same(a, b) {
  if (typeof a === "number" && typeof b === "number") {
    return Math.abs(a - b) <= 1e-9 * Math.max(1, Math.abs(a), Math.abs(b));
  }
  if (Array.isArray(a) && Array.isArray(b)) return a.length === b.length && a.every((v, i) => same(v, b[i]));
  if (a && b && typeof a === "object" && typeof b === "object") {
    const ka = Object.keys(a).sort(), kb = Object.keys(b).sort();
    return same(ka, kb) && ka.every((k) => same(a[k], b[k]));
  }
  return a === b;
}

function onStep() {
  const cfg = state.config, s = L.step;
  return Boolean(cfg && s && !cfg.use_recording && same(cfg.model, s.model) &&
    same(cfg.signal, s.input) && same(cfg.mismatch, s.mismatch));
}

function markExploring() {
  if (!L.step) return;
  const here = onStep();
  if (L.viewOnLoad && state.config) {  // a page (re)loaded on the class step: its view too
    const view = L.viewOnLoad;
    L.viewOnLoad = null;
    if (here && state.fig !== view) selectFigure(view);
  }
  $("lesson").classList.toggle("exploring", !here);
  $("lesson-state").textContent = here
    ? "You are on the class step."
    : "You are exploring: your model or input differs from the class step.";
  document.body.dataset.lessonStep = here ? String(L.step.step) : "exploring";
}

async function backToClass() {
  try {
    const s = await api("POST", `/api/sessions/${encodeURIComponent(state.code)}/lesson/return`);
    applyConfig(s.config, s.version);
    if (L.step) selectFigure(L.step.view);
    else await draw();
  } catch (e) {
    if (e.status === 409) show(null);
    setMsg("model-msg", `Not returned to the class step: ${e.message}`);
  }
}

// the teacher moved the class: session.js has loaded the pushed session already (and
// left the drawing to this)
function onPushed(info) {
  if (!info || !info.lesson) return;
  show(info.lesson);
  // a changed step keeps the view on show; its figure was asked for with the event
  // its texts painted before its figure is drawn
  if (!info.edit) selectFigure(info.lesson.view, info.pending, { textFirst: true });
  else draw(info.pending, { textFirst: true }).catch((e) => setMsg("model-msg", e.message));
  const note = $("live-note");
  note.classList.remove("error");
  const where = `step ${info.lesson.step} of ${info.lesson.steps}: ${info.lesson.step_title}`;
  const what = info.signal && info.model ? "model and input" : info.model ? "model" : "input";
  if (state.teaching) {
    note.textContent = info.edit ? `You changed the class step (${where}): the class's ${what} is now yours.`
      : `You moved the class to ${where}.`;
  } else {
    note.textContent = info.edit
      ? `Your teacher changed the class step (${where}): your ${what} now follow${what === "model and input" ? "" : "s"} it.`
      : `Your teacher moved the class to ${where}. Your model, input and view now follow it.`;
  }
  note.hidden = false;
  // body[data-step-shown] counts the steps (and pushes) this page has shown: their texts,
  // sliders and note are on screen now; the figure follows when it comes (data-ready)
  document.body.dataset.stepShown = String(Number(document.body.dataset.stepShown || 0) + 1);
}

function ended() {
  if (!L.step) return;
  show(null);
  const note = $("live-note");
  note.classList.remove("error");
  note.textContent = "Your teacher ended the lesson. Your page keeps its model and input: explore on.";
  note.hidden = false;
}

// ---------------------------------------------------------------- the teacher's panel
function buildTeacher() {
  const box = el("fieldset", { id: "lesson-teacher", className: "lesson-teacher" },
    el("legend", { textContent: "Lesson" }),
    el("p", { className: "help", textContent: "Lead the class through a lesson: every step gives each student's page its model, input and view, with a prompt. Students may explore and come back." }),
    el("label", {}, "lesson ", el("select", { id: "lesson-pick", title: "The shipped lessons, a loaded lesson file, or the lesson you made" })),
    el("span", { className: "buttons" },
      el("button", { id: "lesson-start", type: "button", textContent: "Start lesson", title: "Send the lesson's first step to every student's page (needs the teacher token)" }),
      el("button", { id: "lesson-prev", type: "button", textContent: "◀ Previous step", title: "Move the class back one step" }),
      el("button", { id: "lesson-next", type: "button", textContent: "Next step ▶", title: "Move the class on to the next step" }),
      el("button", { id: "lesson-end", type: "button", textContent: "End lesson", title: "End the lesson; every page keeps the model it has" })),
    el("label", {}, "load a lesson file (JSON or TOML) ",
      el("input", { type: "file", id: "lesson-file", accept: ".json,.toml,application/json,text/plain", title: "A lesson file (JSON or TOML) saved from here or written by hand" })),
    el("details", { id: "lesson-make" },
      el("summary", { textContent: "Make a lesson from what is on screen" }),
      el("p", { className: "help", textContent: "Each step keeps the model, the input and the view you have now, with your texts. Download the lesson to use it again." }),
      el("label", {}, "lesson title ", el("input", { id: "lesson-new-lesson", value: "My lesson", maxLength: 120 })),
      el("label", {}, "step title ", el("input", { id: "lesson-new-title", maxLength: 120 })),
      el("label", {}, "prompt ", el("textarea", { id: "lesson-new-prompt", rows: 2, maxLength: 2000 })),
      el("label", {}, "look for ", el("textarea", { id: "lesson-new-look", rows: 2, maxLength: 2000 })),
      el("button", { id: "lesson-add", type: "button", textContent: "Add the current state as a step", title: "The model, input, mismatch and view on screen, with the texts above, become the lesson's next step" }),
      el("button", { id: "lesson-download", type: "button", textContent: "Download my lesson", title: "Save the lesson file (JSON) to use it again or share it" }),
      el("button", { id: "lesson-clear", type: "button", textContent: "Clear my lesson", title: "Start a new lesson from no steps (download this one first to keep it)" })),
    el("p", { id: "lesson-msg", className: "msg", role: "status" }));
  $("teacher").append(box);
  $("lesson-start").addEventListener("click", () => teach(startLesson));
  $("lesson-prev").addEventListener("click", () => teach(() => move(-1)));
  $("lesson-next").addEventListener("click", () => teach(() => move(1)));
  $("lesson-end").addEventListener("click", () => teach(endLesson));
  $("lesson-file").addEventListener("change", loadFile);
  $("lesson-add").addEventListener("click", () => addStep().catch((e) => msg(`Not added: ${e.message}`)));
  $("lesson-download").addEventListener("click", downloadDraft);
  $("lesson-clear").addEventListener("click", clearDraft);
}

// the lesson being made survives a reload of the teacher's page (this browser only)
const DRAFT_KEY = "hyst-lesson-draft";

function keepDraft(doc) {
  L.draft = doc;
  try { localStorage.setItem(DRAFT_KEY, JSON.stringify(doc)); } catch { /* private mode: not kept */ }
  if (doc.steps.length) addChoice("draft", `my lesson: ${doc.title} (${steps(doc.steps.length)})`, { lesson: doc });
}

function restoreDraft() {
  let doc = null;
  try { doc = JSON.parse(localStorage.getItem(DRAFT_KEY) || "null"); } catch { doc = null; }
  if (doc && typeof doc.title === "string" && Array.isArray(doc.steps) && doc.steps.length) {
    keepDraft(doc);  // checked again by the server when it starts
    $("lesson-new-lesson").value = doc.title;
  }
}

function clearDraft() {
  L.draft = { title: "My lesson", steps: [] };
  localStorage.removeItem(DRAFT_KEY);
  const opt = [...$("lesson-pick").options].find((o) => o.value === "draft");
  if (opt) opt.remove();
  L.choices.delete("draft");
  msg("Your lesson has no steps now: add the first one.", true);
}

function msg(text, ok = false) { setMsg("lesson-msg", text, ok); }
const steps = (n) => `${n} step${n === 1 ? "" : "s"}`;

function addChoice(key, label, start) {
  L.choices.set(key, start);
  const sel = $("lesson-pick");
  let opt = [...sel.options].find((o) => o.value === key);
  if (!opt) { opt = new Option(label, key); sel.append(opt); } else opt.textContent = label;
  sel.value = key;
}

function syncTeacherButtons() {
  const s = L.step;
  $("lesson-prev").disabled = !s || s.step <= 1;
  $("lesson-next").disabled = !s || s.step >= s.steps;
  $("lesson-end").disabled = !s;
}

async function teach(action) {
  state.token = $("teacher-token").value;
  state.teaching = true;  // the moves this page makes are "you moved the class"
  try {
    const r = await action();
    if (r) {
      show(r);
      msg(r.text || (r.running ? `Step ${r.step} of ${r.steps} sent to ${r.sessions} sessions.`
        : "Lesson ended."), true);
    }
  } catch (e) {
    if (e.status === 403) state.teaching = false;
    msg(e.status === 403 ? "Wrong teacher token: type the token the server was started with above." : `Not done: ${e.message}`);
  }
}

function startLesson() {
  const body = L.choices.get($("lesson-pick").value);
  if (!body) { msg("Pick a lesson first."); return null; }
  return api("POST", "/api/teacher/lesson", body);
}

const move = (d) => api("POST", "/api/teacher/lesson/step", { move: d });
const endLesson = () => api("DELETE", "/api/teacher/lesson");

async function loadFile(ev) {
  const file = ev.target.files[0];
  if (!file) return;
  try {
    // the file's text is the body as it is; the server reads it strictly
    const doc = await api("POST", "/api/lessons/check", await file.text(), "text/plain");
    addChoice(`file:${file.name}`, `file: ${doc.title} (${steps(doc.steps.length)})`, { lesson: doc });
    msg(`Loaded ${file.name}: ${steps(doc.steps.length)}. Start it when the class is ready.`, true);
  } catch (e) {
    msg(`Lesson file not loaded: ${e.message}`);
  } finally {
    ev.target.value = "";
  }
}

async function addStep() {
  const cfg = state.config;
  if (state.fig === "fit") { msg("The Fit view needs each student's own recording: choose another view for a step."); return; }
  const title = $("lesson-new-title").value.trim() || `Step ${L.draft.steps.length + 1}`;
  const step = { title, model: cfg.model, input: cfg.signal, mismatch: cfg.mismatch,
    view: state.fig, prompt: $("lesson-new-prompt").value.trim() || "What do you see?" };
  const look = $("lesson-new-look").value.trim();
  if (look) step.look_for = look;
  const draft = { title: $("lesson-new-lesson").value.trim() || "My lesson", steps: [...L.draft.steps, step] };
  const doc = await api("POST", "/api/lessons/check", draft);  // checked as a file would be
  keepDraft(doc);
  for (const id of ["lesson-new-title", "lesson-new-prompt", "lesson-new-look"]) $(id).value = "";
  msg(`Added step ${doc.steps.length}: ${title}${cfg.use_recording ? " (with the generated input: a recording is not part of a lesson)" : ""}.`, true);
}

function downloadDraft() {
  if (!L.draft.steps.length) { msg("Add a step first: the lesson has none yet."); return; }
  const blob = new Blob([JSON.stringify(L.draft, null, 1) + "\n"], { type: "application/json" });
  const a = el("a", { href: URL.createObjectURL(blob), download: fileName(L.draft.title) });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10_000);
}

function fileName(title) {
  const base = title.toLowerCase().replace(/[^a-z0-9]+/g, "-").replace(/^-+|-+$/g, "").slice(0, 60);
  return `${base || "lesson"}.lesson.json`;
}

// ---------------------------------------------------------------- start
async function start() {
  buildBanner();
  buildTeacher();
  window.addEventListener("hyst:push", (ev) => onPushed(ev.detail));
  window.addEventListener("hyst:lesson", (ev) => { if (!ev.detail || !ev.detail.lesson) ended(); });
  // after every redraw: is this page still on the class step?
  new MutationObserver(markExploring).observe(document.body, { attributes: true, attributeFilter: ["data-ready"] });
  const [list, now] = await Promise.all([api("GET", "/api/lessons"), api("GET", "/api/lesson")]);
  for (const x of list) addChoice(`name:${x.name}`, `${x.title} (${steps(x.steps)})`, { name: x.name });
  restoreDraft();
  $("lesson-pick").value = list.length ? `name:${list[0].name}` : "";
  L.viewOnLoad = now.running ? now.view : null;
  show(now);
}

start().catch((e) => setMsg("model-msg", `Lesson mode did not start: ${e.message}`));
