// Offline REST reference rendered from /openapi.json; every string goes in as text.
const el = (tag, props = {}, ...kids) => {
  const e = Object.assign(document.createElement(tag), props);
  e.append(...kids.filter((k) => k !== null && k !== undefined && k !== ""));
  return e;
};
const ref = (s) => (s && s.$ref ? s.$ref.split("/").pop() : s && s.type ? s.type : "");

const spec = await (await fetch("/openapi.json")).json();
const out = [];
for (const [path, ops] of Object.entries(spec.paths)) {
  for (const [method, op] of Object.entries(ops)) {
    const div = el("div", { className: "op" },
      el("span", { className: "method", textContent: method.toUpperCase() }), " ",
      el("code", { textContent: path }), " ",
      el("b", { textContent: op.summary || "" }));
    for (const para of String(op.description || "").split(/\n\n/)) {
      if (para.trim()) div.append(el("p", { textContent: para }));
    }
    const params = op.parameters || [];
    if (params.length) {
      const table = el("table", {}, el("tr", {}, ...["parameter", "in", "type", ""].map(
        (h) => el("th", { textContent: h }))));
      for (const p of params) {
        const type = ref(p.schema) || (p.schema ? JSON.stringify(p.schema) : "");
        table.append(el("tr", {}, ...[p.name, p.in, type, p.description || ""].map(
          (v) => el("td", { textContent: String(v ?? "") }))));
      }
      div.append(table);
    }
    if (op.requestBody) {
      const body = Object.entries(op.requestBody.content || {})
        .map(([t, c]) => `${t} ${ref(c.schema)}`).join(", ");
      div.append(el("p", { textContent: `body: ${body}` }));
    }
    div.append(el("p", { textContent: `responses: ${Object.keys(op.responses || {}).join(", ")}` }));
    out.push(div);
  }
}
out.push(el("h2", { textContent: "Schemas" }));
for (const [name, s] of Object.entries(spec.components?.schemas || {})) {
  out.push(el("div", { className: "op" }, el("b", { textContent: name }), " ",
    s.description || "", el("pre", { textContent: JSON.stringify(s.properties || s, null, 1) })));
}
document.getElementById("ops").replaceChildren(...out);
document.body.dataset.ready = "1";
