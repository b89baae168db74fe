// A small SVG line plotter for the first seconds of a visit: plotly.js (4.8 MB) takes
// one to three seconds to load and compile, so the page draws the first figures with
// this and hands over to plotly once it is there. It reads the same figure JSON
// (traces with typed arrays, axes with domains, a title, annotations) and draws lines,
// markers and stacked areas with ticks and axis titles; no zoom, no hover. Everything
// is SVG attributes (no style attribute), so a strict Content-Security-Policy holds.

const NS = "http://www.w3.org/2000/svg";
const COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
  "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];

export function values(a) {
  if (a && a.bdata !== undefined) {
    const bin = atob(a.bdata);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return a.dtype === "f8" ? new Float64Array(bytes.buffer) : new Float32Array(bytes.buffer);
  }
  return Array.isArray(a) ? a.map(Number) : [];
}

// half way to white, opaque (cheaper to paint than a translucent fill)
function lighter(color) {
  const m = /^#([0-9a-f]{6})$/i.exec(color);
  if (!m) return color;
  const n = parseInt(m[1], 16);
  const mix = (c) => Math.round((c + 255) / 2);
  return `rgb(${mix(n >> 16)},${mix((n >> 8) & 255)},${mix(n & 255)})`;
}

function node(tag, attrs, text) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
  if (text !== undefined) e.textContent = text;
  return e;
}

function niceTicks(lo, hi, count = 5) {
  if (!(hi > lo)) { hi = lo + 1; lo -= 1; }
  const raw = (hi - lo) / count;
  const mag = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => s >= raw) || raw;
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) out.push(+v.toPrecision(12));
  return out;
}

function axisKey(ref, letter) {
  const suffix = String(ref || letter).slice(1);
  return `${letter}axis${suffix}`;
}

/** Figure ``{data, layout}`` as an SVG element the size of ``el`` (not inserted). */
export function quickPlot(el, data, layout) {
  const W = el.clientWidth || 600, H = el.clientHeight || 400;
  const m = { l: 60, r: 15, t: 40, b: 50, ...(layout.margin || {}) };
  const svg = node("svg", { width: W, height: H, class: "quick-plot", role: "img" });
  svg.append(node("rect", { x: 0, y: 0, width: W, height: H, fill: "#ffffff" }));
  const title = layout.title && layout.title.text;
  if (title) {
    svg.append(node("text", { x: W / 2, y: 22, "text-anchor": "middle", "font-size": 14,
      "font-family": "sans-serif", fill: "#333" }, String(title).replace(/<[^>]*>/g, " ")));
  }
  // group the traces by their axis pair, stacking areas of one stackgroup
  const panels = new Map();
  const stacks = new Map();
  data.forEach((tr, i) => {
    if (tr.visible === false || (tr.type && tr.type !== "scatter")) return;
    const xk = axisKey(tr.xaxis, "x"), yk = axisKey(tr.yaxis, "y");
    const key = `${xk}|${yk}`;
    if (!panels.has(key)) panels.set(key, { xk, yk, traces: [] });
    const x = values(tr.x), y0 = values(tr.y);
    let y = y0, base = null;
    if (tr.stackgroup) {
      base = stacks.get(tr.stackgroup) || new Float64Array(y0.length);
      y = Float64Array.from(y0, (v, j) => v + base[j]);
      stacks.set(tr.stackgroup, y);
    }
    const color = (tr.line && tr.line.color) || (tr.marker && tr.marker.color) || COLORS[i % COLORS.length];
    panels.get(key).traces.push({ x, y, color, mode: tr.mode || "lines", dash: tr.line && tr.line.dash,
      width: (tr.line && tr.line.width) || 2, shape: tr.line && tr.line.shape, base });
  });
  for (const { xk, yk, traces } of panels.values()) {
    const xa = layout[xk] || {}, ya = layout[yk] || {};
    const [dx0, dx1] = xa.domain || [0, 1], [dy0, dy1] = ya.domain || [0, 1];
    const px0 = m.l + dx0 * (W - m.l - m.r), px1 = m.l + dx1 * (W - m.l - m.r);
    const py0 = H - m.b - dy0 * (H - m.t - m.b), py1 = H - m.b - dy1 * (H - m.t - m.b);
    let [xlo, xhi] = xa.range || [Infinity, -Infinity], [ylo, yhi] = ya.range || [Infinity, -Infinity];
    if (!xa.range || !ya.range) {
      for (const t of traces) {
        for (let j = 0; j < t.x.length; j++) {
          const a = t.x[j], b = t.y[j];
          if (!Number.isFinite(a) || !Number.isFinite(b)) continue;
          if (!xa.range) { xlo = Math.min(xlo, a); xhi = Math.max(xhi, a); }
          if (!ya.range) { ylo = Math.min(ylo, b); yhi = Math.max(yhi, b); }
        }
      }
    }
    if (!(xhi > xlo)) { xlo -= 1; xhi += 1; }
    if (!(yhi > ylo)) { ylo -= 1; yhi += 1; }
    const pad = 0.04 * (yhi - ylo);
    ylo -= pad; yhi += pad;
    const sx = (v) => px0 + ((v - xlo) / (xhi - xlo)) * (px1 - px0);
    const sy = (v) => py0 + ((v - ylo) / (yhi - ylo)) * (py1 - py0);
    const g = node("g", {});
    g.append(node("rect", { x: px0, y: py1, width: px1 - px0, height: py0 - py1, fill: "none", stroke: "#dddddd" }));
    for (const v of niceTicks(xlo, xhi)) {
      g.append(node("line", { x1: sx(v), x2: sx(v), y1: py0, y2: py1, stroke: "#eeeeee" }));
      if (xa.showticklabels !== false) {
        g.append(node("text", { x: sx(v), y: py0 + 14, "text-anchor": "middle", "font-size": 11, "font-family": "sans-serif", fill: "#444" }, String(v)));
      }
    }
    for (const v of niceTicks(ylo, yhi, 4)) {
      g.append(node("line", { x1: px0, x2: px1, y1: sy(v), y2: sy(v), stroke: "#eeeeee" }));
      g.append(node("text", { x: px0 - 5, y: sy(v) + 4, "text-anchor": "end", "font-size": 11, "font-family": "sans-serif", fill: "#444" }, String(v)));
    }
    const xt = xa.title && xa.title.text, yt = ya.title && ya.title.text;
    if (xt) g.append(node("text", { x: (px0 + px1) / 2, y: py0 + 32, "text-anchor": "middle", "font-size": 12, "font-family": "sans-serif", fill: "#333" }, xt));
    if (yt) {
      const cx = px0 - 42, cy = (py0 + py1) / 2;
      g.append(node("text", { x: cx, y: cy, "text-anchor": "middle", "font-size": 12, "font-family": "sans-serif", fill: "#333", transform: `rotate(-90 ${cx} ${cy})` }, yt));
    }
    for (const t of traces) {
      let d = "", pen = false;
      for (let j = 0; j < t.x.length; j++) {
        const a = t.x[j], b = t.y[j];
        if (!Number.isFinite(a) || !Number.isFinite(b)) { pen = false; continue; }
        if (pen && t.shape === "hv") d += `H${sx(a).toFixed(1)}`;
        d += `${pen ? "L" : "M"}${sx(a).toFixed(1)},${sy(b).toFixed(1)}`;
        pen = true;
      }
      if (t.base) {  // a stacked band: fill down to the band below
        let back = "";
        for (let j = t.x.length - 1; j >= 0; j--) {
          if (Number.isFinite(t.x[j]) && Number.isFinite(t.base[j])) back += `L${sx(t.x[j]).toFixed(1)},${sy(t.base[j]).toFixed(1)}`;
        }
        g.append(node("path", { d: `${d}${back}Z`, fill: lighter(t.color), stroke: "none" }));
      }
      if (t.mode.includes("lines")) {
        g.append(node("path", { d, fill: "none", stroke: t.color, "stroke-width": t.width,
          "stroke-dasharray": t.dash === "dash" ? "6,4" : t.dash === "dot" ? "2,3" : "none" }));
      }
      if (t.mode.includes("markers") && t.x.length <= 500) {
        for (let j = 0; j < t.x.length; j++) {
          if (Number.isFinite(t.x[j]) && Number.isFinite(t.y[j])) {
            g.append(node("circle", { cx: sx(t.x[j]), cy: sy(t.y[j]), r: 3, fill: t.color }));
          }
        }
      }
    }
    svg.append(g);
  }
  for (const a of layout.annotations || []) {
    if (a.xref !== "paper" || a.yref !== "paper") continue;
    const x = m.l + a.x * (W - m.l - m.r), y = H - m.b - a.y * (H - m.t - m.b);
    String(a.text || "").split("<br>").forEach((line, k) => {
      svg.append(node("text", { x, y: y + 14 * k, "text-anchor": a.xanchor === "left" ? "start" : "middle",
        "font-size": 12, "font-family": "sans-serif", fill: "#333" }, line.replace(/<[^>]*>/g, "")));
    });
  }
  return svg;
}
