// Drawing a figure: quickplot.js while plotly.js loads or a control moves, then plotly;
// the layout fitted to a phone's width and to projector mode.

import { $, setMsg } from "/dom.js";
import { quickPlot, values } from "/quickplot.js";
import { state } from "/store.js";

// plotly's toolbar without anything that talks to an outside service
const PLOT_CONFIG = {
  responsive: true, displaylogo: false, showLink: false, showSendToCloud: false,
  showEditInChartStudio: false, plotlyServerURL: "", linkText: "",
  modeBarButtonsToRemove: ["sendDataToCloud", "sendChartToCloud", "editInChartStudio"],
  // SVG is written straight from the plot; PNG would load a blob: image, which the
  // server's Content-Security-Policy (default-src 'self') blocks
  toImageButtonOptions: { format: "svg", filename: "hysteresis-explorer" },
};

// On a phone the side-by-side panels of a figure are stacked: the axes of each column
// (x axes sharing a horizontal domain) get a band of the height, top to bottom.
function fitLayout(layout) {
  const fig = $("figure");
  const keys = Object.keys(layout);
  const xs = keys.filter((k) => /^xaxis\d*$/.test(k));
  const cols = [], colOf = {};
  for (const k of xs) {
    const d = JSON.stringify(layout[k].domain || [0, 1]);
    if (!cols.includes(d)) cols.push(d);
    colOf[k] = cols.indexOf(d);
  }
  const narrow = fig.clientWidth < 600;
  const stack = narrow && cols.length > 1;
  fig.classList.toggle("tall", stack);
  if (!narrow) return layout;
  const lay = structuredClone(layout);
  if (lay.title) belowToolbar(lay, 11);
  // plotly keeps the height it measured last; the element grows when panels are stacked
  // (style.css .plot.tall), and the old height left a screen of blank space under them
  lay.height = fig.clientHeight;
  if (!stack) return lay;
  const band = 1 / cols.length, gap = 0.25 * band;  // room for tick labels and a title
  for (const k of xs) lay[k].domain = [0, 1];
  const ys = keys.filter((k) => /^yaxis\d*$/.test(k));
  const colOfY = (k) => {
    const anchor = String(lay[k].anchor || "x");
    return colOf["xaxis" + (anchor.startsWith("x") ? anchor.slice(1) : "")] ?? 0;
  };
  // a column's axes fill its band (the room left under them for side notes, which a phone
  // leaves out, was a blank screen)
  const low = cols.map((_, c) => Math.min(...ys.filter((k) => colOfY(k) === c)
    .map((k) => (lay[k].domain || [0, 1])[0]), 1));
  for (const k of ys) {
    const c = colOfY(k);
    const lo = low[c] < 1 ? low[c] : 0;
    const [a, b] = (lay[k].domain || [0, 1]).map((v) => (v - lo) / (1 - lo));
    // (the last band's tick labels and axis title go in the bottom margin)
    const top = 1 - c * band, bottom = top - band + (c === cols.length - 1 ? 0 : gap);
    lay[k].domain = [bottom + a * (top - bottom), bottom + b * (top - bottom)];
  }
  lay.margin = { ...(lay.margin || {}), l: 50, r: 10, b: 45 };
  // side notes in monospace (the digitized view's matrices) have no room left
  lay.annotations = (lay.annotations || []).filter((a) => !(a.font && a.font.family === "monospace"));
  lay.showlegend = false;
  return lay;
}

// On a phone the names of many points pile on each other (a digitized state diagram's
// 7-digit states): only a trace of a few points keeps its labels, drawn past the plot's
// edge if need be and on the side of the point facing the middle (a label at the left
// edge was cut).
const PHONE_LABELS = 3;
function phoneData(el, data) {
  if (el.clientWidth >= 600) return data;
  return data.map((t) => {
    if (!t.mode || !t.mode.includes("text")) return t;
    const own = values(t.x);
    if (own.length > PHONE_LABELS) return { ...t, mode: t.mode.replace(/\+?text/, "") || "markers" };
    let lo = Infinity, hi = -Infinity;
    for (const u of data) {
      if ((u.xaxis || "x") !== (t.xaxis || "x")) continue;
      for (const v of values(u.x)) if (Number.isFinite(v)) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    }
    const side = own.length && own[0] > (lo + hi) / 2 ? "left" : "right";
    const vert = String(t.textposition || "top").split(" ")[0];
    return { ...t, cliponaxis: false, textposition: `${vert === "middle" ? "top" : vert} ${side}` };
  });
}

// On a phone plotly's toolbar (a row of about 30 px at the top right) sat on the title: the
// title is wrapped to the width, set in small type and starts below the toolbar's row.
const TOOLBAR_PX = 36;
function belowToolbar(lay, size) {
  if (typeof lay.title !== "object") lay.title = { text: lay.title };
  lay.title = { ...lay.title, font: { ...(lay.title.font || {}), size } };
  wrapTitle(lay, size);
  const lines = String(lay.title.text || "").split("<br>").length;
  lay.title = { ...lay.title, x: 0.5, xanchor: "center", y: 1, yref: "container", yanchor: "top",
    pad: { t: TOOLBAR_PX } };
  lay.margin = { ...(lay.margin || {}), t: Math.max((lay.margin && lay.margin.t) || 0,
    TOOLBAR_PX + Math.ceil(lines * size * 1.3) + 12) };
}

// While a control is being moved, plotly's redraw (30-200 ms for these figures) is the
// slow part of a step: the frames of a drag are drawn by quickplot.js over the plot, and
// plotly redraws once the control has rested for SETTLE_MS (keeping zoom and toolbar).
export const SETTLE_MS = 350;

function zoomed(layout) {
  const fl = $("figure")._fullLayout;
  if (!fl) return layout;
  const lay = { ...layout };
  for (const k of Object.keys(lay)) {
    if (/^[xy]axis\d*$/.test(k) && fl[k] && fl[k].autorange === false && Array.isArray(fl[k].range)) {
      lay[k] = { ...lay[k], range: fl[k].range.slice() };
    }
  }
  return lay;
}

// Projector mode: every text of the plot at least 16 px (app/services/explore/figures.py's
// large_text does the same for viser).
function largeText(layout, size = 16) {
  const lay = structuredClone(layout);
  lay.font = { ...(lay.font || {}), size };
  if (lay.title && typeof lay.title === "object") lay.title = { ...lay.title, font: { ...(lay.title.font || {}), size: size + 4 } };
  lay.legend = { ...(lay.legend || {}), font: { size } };
  for (const k of Object.keys(lay)) {
    if (!/^[xy]axis\d*$/.test(k) || !lay[k]) continue;
    lay[k] = { ...lay[k], tickfont: { ...(lay[k].tickfont || {}), size } };
    if (lay[k].title && typeof lay[k].title === "object") {
      lay[k].title = { ...lay[k].title, font: { ...(lay[k].title.font || {}), size: size + 2 } };
    }
  }
  lay.annotations = (lay.annotations || []).map((a) => ({ ...a, font: { ...(a.font || {}), size: Math.max(size, (a.font && a.font.size) || 0) } }));
  wrapTitle(lay, size + 4);
  return lay;
}

// A title wider than the plot at this size is broken into lines at spaces (plotly cuts a
// long title at both edges), and the top margin grows to hold them.
function wrapTitle(lay, size) {
  const t = lay.title;
  const text = t && typeof t === "object" ? t.text : t;
  if (typeof text !== "string" || !text) return;
  const room = Math.max(10, Math.floor((($("figure").clientWidth || 800) - 40) / (0.56 * size)));
  const lines = [];
  for (const part of text.split("<br>")) {
    let line = "";
    for (const word of part.split(" ")) {
      if (line && (line + " " + word).replace(/<[^>]*>/g, "").length > room) { lines.push(line); line = word; }
      else line = line ? `${line} ${word}` : word;
    }
    lines.push(line);
  }
  if (lines.length < 2) return;
  lay.title = { ...(typeof t === "object" ? t : {}), text: lines.join("<br>") };
  lay.margin = { ...(lay.margin || {}), t: Math.max((lay.margin && lay.margin.t) || 0, Math.ceil(lines.length * size * 1.3 + 24)) };
}

export function setProjector(on) {
  document.body.classList.toggle("projector", on);
  $("projector").setAttribute("aria-pressed", String(on));
  localStorage.setItem("hyst-projector", on ? "1" : "");
  if (state.shown) render($("figure"), state.shown).catch((e) => setMsg("model-msg", e.message));
}

// In projector mode or with a lesson's step above it, the plot takes the height left on the
// screen below its top (less the notes and the status line under it, at least two lines),
// so its axis titles, its legend and what the notes say are never below the fold; a phone
// keeps its own heights (style.css).
export function fitHeight(el = $("figure")) {
  const lesson = document.getElementById("lesson");
  const fit = window.innerWidth > 820 &&
    (document.body.classList.contains("projector") || Boolean(lesson && !lesson.hidden));
  if (!fit) {
    el.style.height = "";
    el.style.minHeight = "";
    return false;
  }
  const top = el.getBoundingClientRect().top + window.scrollY;
  const line = parseFloat(getComputedStyle(document.body).lineHeight) || 24;
  el.style.minHeight = "320px";
  const below = ["notes", "status"].map((id) => document.getElementById(id))
    .reduce((sum, e) => sum + (e ? e.getBoundingClientRect().height : 0), 0);
  const under = Math.max(2 * line, below) + 24;
  el.style.height = `${Math.max(320, Math.floor(window.innerHeight - top - under))}px`;
  return true;
}
window.addEventListener("resize", () => fitHeight());

// What plotly last drew in an element, as the arguments it was given (JSON).
const DRAWN = new WeakMap();

// ``stamp``: what ``f`` is (``view@version``), put in body[data-plotted] once plotly has
// drawn it (a quick plot is not plotly's figure yet).
export async function render(el, f, { live = false, stamp } = {}) {
  if (el.id === "figure" && (f !== state.shown || stamp !== undefined)) state.shownStamp = stamp || "";
  state.shown = f;
  const fitted = el.id === "figure" && fitHeight(el);
  let layout = fitLayout(f.layout);
  // plotly keeps the height it measured last: the height left on the screen, said
  if (fitted) layout = { ...layout, height: el.clientHeight };
  const data = el.id === "figure" ? phoneData(el, f.data) : f.data;
  if (document.body.classList.contains("projector")) layout = largeText(layout);
  const old = el.querySelector(":scope > .quick-plot");
  if (!window.Plotly || live) {
    const svg = quickPlot(el, data, window.Plotly ? zoomed(layout) : layout);
    if (window.Plotly) {
      svg.classList.add("overlay");
      if (old) old.replaceWith(svg); else el.append(svg);
      el.classList.add("live");  // plotly's own SVG is hidden (not repainted) meanwhile
      clearTimeout(state.settle);
      state.settle = setTimeout(() => {
        render(el, state.shown).catch((e) => setMsg("model-msg", e.message));
      }, SETTLE_MS);
    } else {
      el.replaceChildren(svg);
    }
    return;
  }
  clearTimeout(state.settle);
  if (old && !old.classList.contains("overlay")) el.replaceChildren();
  const t0 = performance.now();
  const mine = el.id === "figure" ? state.shownStamp : null;
  // the same figure at the same size (a lesson's step that changed only its texts, the
  // same view asked again): plotly's redraw, a long task, is not run again
  const key = JSON.stringify([data, layout]);
  if (old || key !== DRAWN.get(el) || !el.classList.contains("js-plotly-plot")) {
    DRAWN.delete(el);
    await Plotly.react(el, data, layout, PLOT_CONFIG);
    DRAWN.set(el, key);
  }
  if (old && old.classList.contains("overlay")) old.remove();
  el.classList.remove("live");
  document.body.dataset.plotlyMs = (performance.now() - t0).toFixed(1);
  document.body.dataset.settled = document.body.dataset.ready || "";
  if (mine !== null && state.shown === f) document.body.dataset.plotted = mine || "";
}
