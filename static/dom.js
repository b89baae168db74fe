// Small DOM helpers. Every string from the server or a file goes in as text (textContent,
// new Option), never as markup.

export const $ = (id) => document.getElementById(id);

export function setMsg(id, text, ok = false) {
  const el = $(id);
  el.textContent = text || "";
  el.classList.toggle("ok", ok);
  el.classList.remove("rule");
}

// Text set only when it changes: the same words again would be a DOM change (and a frame
// of layout) for nothing; a page that is told its step twice shows it once.
export function setText(id, text) {
  const node = $(id);
  if (node.textContent !== text) node.textContent = text;
}

export function el(tag, props = {}, ...kids) {
  const e = Object.assign(document.createElement(tag), props);
  e.append(...kids.filter((k) => k !== null && k !== undefined && k !== ""));
  return e;
}

export function showOutput(input, value = input.value) {
  const text = Number(value).toFixed(3).replace(/\.?0+$/, "");
  const box = $(`${input.id}-num`);  // a number box beside the slider (exact values)
  if (box) box.value = text;
  const out = document.querySelector(`output[for="${input.id}"]`);
  if (out) out.textContent = text;
}

// The value of slider `id`: its number box's when that holds a number in the slider's
// range (finer than the slider's step), else the slider's.
export function sliderValue(id) {
  const input = $(id), box = $(`${id}-num`);
  const v = box ? Number(box.value) : NaN;
  if (box && box.value.trim() !== "" && v >= Number(input.min) && v <= Number(input.max)) return v;
  return Number(input.value);
}

// A number typed in slider `id`'s box: held to the slider's range (said in `onNote`), put
// on the slider, then `onChange()`.
export function numberTyped(id, onChange, onNote) {
  const input = $(id), box = $(`${id}-num`);
  const typed = Number(box.value);
  if (box.value.trim() === "" || !Number.isFinite(typed)) {
    showOutput(input);
    onNote(`${box.getAttribute("aria-label").split(",")[0]} needs a number`);
    return;
  }
  const v = Math.min(Number(input.max), Math.max(Number(input.min), typed));
  if (v !== typed) onNote(`${input.id} stops at ${v}: its range is ${input.min} to ${input.max}`);
  input.value = String(v);
  box.value = String(v);
  onChange();
}
