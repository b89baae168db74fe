// Small DOM helpers. Every string from the server or a file goes in as text (textContent,
// new Option), never as markup.

export const $ = (id) => document.getElementById(id);

export function setMsg(id, text, ok = false) {
  const el = $(id);
  el.textContent = text || "";
  el.classList.toggle("ok", ok);
  el.classList.remove("rule");
}

export function el(tag, props = {}, ...kids) {
  const e = Object.assign(document.createElement(tag), props);
  e.append(...kids.filter((k) => k !== null && k !== undefined && k !== ""));
  return e;
}

export function showOutput(input) {
  const out = document.querySelector(`output[for="${input.id}"]`);
  if (out) out.textContent = Number(input.value).toFixed(3).replace(/\.?0+$/, "");
}
