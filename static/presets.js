// The preset dropdown and its description, kept in step with the session's model.

import { $ } from "/dom.js";
import { state } from "/store.js";

export function showPresetDesc() {
  const p = state.presets.find((x) => x.name === $("preset").value);
  let text = p ? p.description : "";
  if (p && state.presetChanged) text = `The session's model started from this preset and was changed since. ${text}`;
  else if (!p && $("preset").value === CHANGED) text = "The session's model is not one of the presets (changed with the sliders, the JSON, a fit or a saved set); pick a preset to start over.";
  $("preset-desc").textContent = text;
}

// The preset dropdown shows the session's preset (after a reload, a rejoin or a push):
// the preset whose model is the session's; on a freshly opened page whose model was
// changed, the preset this browser last loaded into the session, else "a changed model".
const CHANGED = "";
function canonical(v) {
  if (Array.isArray(v)) return `[${v.map(canonical).join(",")}]`;
  if (v && typeof v === "object") {
    return `{${Object.keys(v).sort().map((k) => `${JSON.stringify(k)}:${canonical(v[k])}`).join(",")}}`;
  }
  return JSON.stringify(v);
}

// After a fit the model is the recording's, not the preset's: the box says so.
export function showFitted() {
  const sel = $("preset");
  let placeholder = sel.querySelector(`option[value="${CHANGED}"]`);
  if (!placeholder) { placeholder = new Option("", CHANGED); sel.prepend(placeholder); }
  placeholder.textContent = "(a model fitted to the recording)";
  sel.value = CHANGED;
  state.presetChanged = false;
  $("preset-desc").textContent = "The session's model was fitted to the recording. Pick a preset and load it to start from a paper's model again.";
}

export function syncPreset(model, { fresh = false } = {}) {
  const key = `hyst-preset:${state.code}`;
  const want = canonical(model);
  const match = state.presets.find((p) => canonical(p.model) === want);
  const sel = $("preset");
  const placeholder = sel.querySelector(`option[value="${CHANGED}"]`);
  let name = null;
  state.presetChanged = false;
  if (match) {
    name = match.name;
    localStorage.setItem(key, name);
  } else if (fresh) {
    const remembered = localStorage.getItem(key);
    if (state.presets.some((p) => p.name === remembered)) {
      name = remembered;
      state.presetChanged = true;
    } else {
      name = CHANGED;
    }
  }
  if (name === null) return;
  if (name === CHANGED && !placeholder) sel.prepend(new Option("(a changed model)", CHANGED));
  else if (name === CHANGED) placeholder.textContent = "(a changed model)";
  if (name !== CHANGED && placeholder) placeholder.remove();
  sel.value = name;
  showPresetDesc();
}
