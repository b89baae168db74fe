// The model's parameter sliders, built from the server's description of the model
// (POST /api/controls, derived from each model type's field declarations): any model type
// gets its sliders here without code of its own.
//
// The sliders edit a working copy of the model document (`controls.model`). A move is kept
// inside the field's rules before it is sent, by the server (POST /api/controls/clamp: whole
// numbers, hard limits, and the order of increasing fields, a threshold one step short of its
// neighbour; no copy of the rules here); the note says so in the labels the user sees. `revert` puts the sliders back at the last model the server
// accepted, so a refused change never blocks the next one.

const TOKENS = /[^.[\]]+|\[\d+\]/g;

function tokens(path) {
  return path.match(TOKENS) || [];
}

export function getLeaf(doc, path) {
  let node = doc;
  for (const t of tokens(path)) {
    if (node === null || node === undefined) return undefined;
    node = t.startsWith("[") ? node[Number(t.slice(1, -1))] : node[t];
  }
  return node;
}

export function setLeaf(doc, path, value) {
  const ts = tokens(path);
  let node = doc;
  for (const t of ts.slice(0, -1)) node = t.startsWith("[") ? node[Number(t.slice(1, -1))] : node[t];
  const last = ts[ts.length - 1];
  if (last.startsWith("[")) node[Number(last.slice(1, -1))] = value;
  else node[last] = value;
}

// The structure of a model document: types, keys and lengths (numbers left out).
function shape(doc) {
  return JSON.stringify(doc, (k, v) => (typeof v === "number" ? 0 : v));
}

function fmt(x) {
  return String(Number(x.toPrecision(6)));
}

// A log slider (s.log) moves its thumb in log10 of the value: position <-> value.
const LOG_STEPS_PER_DECADE = 200;

export function position(s, v) {
  return s.log ? Math.log10(Math.max(v, s.min)) : v;
}

export function valueAt(s, pos) {
  return s.log ? Number((10 ** pos).toPrecision(3)) : pos;
}

const UNIT_TEXT = {
  input: "input units", output: "output units", "output/input": "output per input unit",
  "1/input": "per input unit", s: "s", Hz: "Hz", "s^k": "s to the power of the term", 1: "",
};

// `parent`'s children made `kids`, in order, touching only what differs: a kept node that
// is already in its place is not moved (a focused slider keeps its focus).
export function place(parent, kids) {
  // the nodes that go first, so a kept one after them need not move (moving blurs it)
  const keep = new Set(kids);
  for (const c of [...parent.children]) if (!keep.has(c)) c.remove();
  kids.forEach((kid, i) => {
    const at = parent.children[i];
    if (at !== kid) parent.insertBefore(kid, at ?? null);
  });
}

export class ModelControls {
  // container: the element the groups go in; api(method, path, body): the page's fetch
  // helper; onChange(note): called after a slider moved (note: what a rule changed, or "")
  constructor(container, { api, onChange }) {
    this.box = container;
    this.api = api;
    this.onChange = onChange;
    this.model = null;
    this.desc = null;
    this.byPath = new Map();
    this.inputs = new Map();
    this.groups = new Map();  // group key -> its <details>, kept across rebuilds
    this.labels = new Map();  // slider path -> { label, input, out, ref }, kept likewise
    this.seq = 0;  // models shown from outside: a reply asked for before the newest is stale
    this.shape = null;
    this.pending = new Map();  // path -> the slider's newest move not yet clamped
    this.clamping = false;
  }

  // Show `model` (a change that did not come from these sliders): the sliders are rebuilt
  // from the server's description when the structure changed, else moved to the values.
  async show(model) {
    // moves not yet clamped, and replies on their way, belong to the model this replaces:
    // dropped, so that they neither write into it nor clear what its change said
    this.pending.clear();
    const seq = ++this.seq;
    this.model = structuredClone(model);
    const same = this.desc && this.shape === shape(model);
    if (same && this.#setValues()) return;
    let desc;
    try {
      desc = await this.api("POST", "/api/controls", { model });
    } catch (e) {
      if (seq !== this.seq) return;
      this.desc = null;
      this.shape = null;
      this.box.replaceChildren(Object.assign(document.createElement("p"), {
        className: "msg", textContent: `No sliders for this model: ${e.message}`,
      }));
      return;
    }
    if (seq !== this.seq) return;  // a newer model is on its way
    this.desc = desc;
    this.shape = shape(model);
    this.#build();
    this.#setValues();
  }

  // Back to the last accepted model (after a refused change).
  revert(model) {
    this.model = structuredClone(model);
    if (!this.desc || this.shape !== shape(model) || !this.#setValues()) this.show(model);
  }

  // The groups and sliders of `this.desc`. A group (by key) and a slider (by path) that
  // were on show are kept, their text, range and state set in place, so a structural change
  // (an operator added, another model type) only builds what is new: the elements, their
  // focus and the open / closed state a user chose for a group stay.
  #build() {
    this.byPath.clear();
    this.inputs.clear();
    const groups = new Map();
    const labels = new Map();
    const boxes = this.desc.groups.map((g) => {
      let box = this.groups.get(g.key);
      if (box === undefined) {
        box = document.createElement("details");
        box.className = "ctl-group";
        box.dataset.key = g.key;
        box.open = g.sliders.length <= 8;
        box.append(document.createElement("summary"));
      }
      groups.set(g.key, box);
      const summary = box.firstElementChild;
      const title = g.title + (g.unit ? ` (${g.unit})` : "");
      if (summary.textContent !== title) summary.textContent = title;
      let note = box.querySelector(":scope > p.help");
      if (g.note) {
        note ??= Object.assign(document.createElement("p"), { className: "help" });
        if (note.textContent !== g.note) note.textContent = g.note;
      }
      const kids = [summary, ...(g.note ? [note] : []), ...g.sliders.map((s) => {
        const kept = this.labels.get(s.path) ?? this.#slider(s);
        this.#spec(kept, s);
        labels.set(s.path, kept);
        return kept.label;
      })];
      place(box, kids);
      return box;
    });
    this.groups = groups;
    this.labels = labels;
    place(this.box, boxes);
  }

  // A new slider's elements (`ref.s`, its spec, is set by #spec and read by the handlers).
  #slider(s) {
    const ref = { s };
    const label = document.createElement("label");
    label.className = "ctl";
    const name = document.createTextNode("");
    const input = Object.assign(document.createElement("input"), {
      type: "range",
      id: `ctl-${s.path.replace(/[^A-Za-z0-9]+/g, "-").replace(/-$/, "")}`,
    });
    input.dataset.path = s.path;
    // a number box beside the slider for exact values (a finger cannot move a thumb by a
    // few pixels on a phone); its value goes through the same rules as a drag
    const out = Object.assign(document.createElement("input"), {
      type: "number", className: "ctl-num", step: "any", inputMode: "decimal",
      id: `${input.id}-num`,
    });
    label.append(name, input, out);
    input.addEventListener("input", () => this.#moved(ref.s, input, out));
    out.addEventListener("change", () => {
      const s = ref.s;
      const typed = Number(out.value);
      if (out.value.trim() === "" || !Number.isFinite(typed)) {
        out.value = fmt(getLeaf(this.model, s.path));
        this.onChange(`${s.label} needs a number`);
        return;
      }
      this.#moved(s, input, out, Math.min(s.max, Math.max(s.min, typed)), typed);
    });
    return { label, name, input, out, ref };
  }

  // Put spec `s` on a slider's elements (new or kept), changing only what differs.
  #spec(kept, s) {
    const { label, name, input, out, ref } = kept;
    ref.s = s;
    this.byPath.set(s.path, s);
    this.inputs.set(s.path, { input, out });
    const unit = UNIT_TEXT[s.unit] ?? s.unit;
    let title = `${s.label}${unit ? ` in ${unit}` : ""}${s.rule ? `; ${s.rule}` : ""}`;
    if (s.log) title += "; logarithmic scale";
    if (s.fixed) title += "; a constant of this model";
    const attrs = [
      [label, "title", title], [name, "data", `${s.label} `],
      [input, "min", String(position(s, s.min))], [input, "max", String(position(s, s.max))],
      [input, "step", String(s.log ? 1 / LOG_STEPS_PER_DECADE : s.step)],
      [input, "disabled", Boolean(s.fixed)], [out, "disabled", Boolean(s.fixed)],
    ];
    for (const [node, key, v] of attrs) if (node[key] !== v) node[key] = v;
    if (s.log) input.dataset.scale = "log";
    else delete input.dataset.scale;
    if (input.getAttribute("aria-label") !== s.label) input.setAttribute("aria-label", s.label);
    const exact = `${s.label}, exact value`;
    if (out.getAttribute("aria-label") !== exact) out.setAttribute("aria-label", exact);
  }

  // Put the working model's values on the sliders; false when one lies outside its
  // slider's range (the caller then asks for a new description).
  #setValues() {
    for (const [path, { input, out }] of this.inputs) {
      const v = getLeaf(this.model, path);
      if (typeof v !== "number") return false;
      const s = this.byPath.get(path);
      if (v < s.min || v > s.max) return false;
      input.value = String(position(s, v));
      input.setAttribute("aria-valuetext", fmt(v));
      out.value = fmt(v);
    }
    return true;
  }

  // The rules of the field (limits, neighbours) are the server's (POST /api/controls/clamp,
  // the viser GUI's too), then the working model and the page. One request at a time; of
  // the moves of one slider made meanwhile the newest wins. `typed`: the number box's value
  // (else the slider's position), `asked` what was typed before the slider's range held it
  async #moved(s, input, out, typed = null, asked = typed) {
    const value = typed ?? valueAt(s, Number(input.value));
    this.pending.delete(s.path);  // (re-inserted last: the slider's newest move)
    this.pending.set(s.path, { s, input, out, typed, asked, value });
    if (this.clamping) return;
    this.clamping = true;
    try {
      while (this.pending.size) {
        const [path, m] = this.pending.entries().next().value;
        this.pending.delete(path);
        let done;
        const seq = this.seq;
        try {
          done = await this.api("POST", "/api/controls/clamp", { model: this.model, path, value: m.value });
        } catch (e) {
          if (seq === this.seq) this.onChange(e.message);
          continue;
        }
        if (seq !== this.seq) continue;  // another model was shown meanwhile
        // else a newer move is pending; a slider whose spec was replaced meanwhile (a new
        // model's structure) shows the new model's value, not this reply on the old scale
        if (!this.pending.has(path) && this.byPath.get(path) === m.s) {
          this.#show(m, done.value, done.note);
        }
      }
    } finally {
      this.clamping = false;
    }
  }

  #show({ s, input, out, typed, asked }, v, note) {
    const pos = String(position(s, v));
    if (pos !== input.value) input.value = pos;
    input.setAttribute("aria-valuetext", fmt(v));
    out.value = fmt(v);
    setLeaf(this.model, s.path, v);
    const held = asked !== null && asked !== typed && !note
      ? `${s.label} stops at ${fmt(v)}: the slider's range is ${fmt(s.min)} to ${fmt(s.max)}` : "";
    this.onChange(note || held);
  }
}
