// The REST client: one fetch helper whose errors carry a message for people (server
// messages that name command-line options are rewritten, bare statuses explained).

import { state } from "/store.js";

// ---------------------------------------------------------------- messages
// Server messages are written for the command line too; a few parts of them name
// arguments or endpoints a page user never sees, so they are rewritten here.
const REWRITES = [
  [/: no such file; to parse CSV text pass a string that contains newlines/,
    " holds a single line: a recording needs a header line and one line per sample"],
  [/;?\s*pass skiprows= to choose yourself/, "; delete the lines above the table"],
  [/if the file starts with a preamble, pass skiprows=/, "if notes stand above the table, delete them"],
  [/pass header=True/, "give the file a header line with the column names"],
  [/pass a larger max_rows= to read it anyway, or cut \/ decimate the recording/, "cut or decimate the recording"],
  [/;?\s*pass a larger max_bytes= to (read it anyway|)/, "; make the file smaller "],
  [/\s*\((GET|POST|PUT|PATCH|DELETE) \/api[^)]*\)/g, ""],
  [/;\s*pass run=<id> to choose another or run=all to read every row/, "; choose another run below"],
  [/\s*\(run=all\)/, ""],
  [/max_operators/g, "the operator limit"],
  [/max_samples/g, "the sample limit"],
];
export const STATUS_TEXT = {
  404: "The server does not know this (it may have been restarted).",
  405: "This server does not offer that action (is it an older version?).",
  413: "The file is too large for this server.",
  415: "The file type is not accepted: upload a CSV text file.",
  429: "Too many requests at once: wait a moment and try again.",
  500: "The server hit an unexpected problem. Try again; if it repeats, tell whoever runs it.",
  503: "The server is busy: try again in a moment.",
};

export function plain(text) {
  let t = String(text ?? "");
  for (const [re, rep] of REWRITES) t = t.replace(re, rep);
  return t.trim();
}

export function detailText(d) {
  if (typeof d === "string") return d;
  if (Array.isArray(d)) {  // FastAPI validation errors: [{loc, msg}]
    return d.map((e) => `${(e.loc || []).filter((x) => x !== "body").join(".")}: ${e.msg}`).join("; ");
  }
  if (d && d.message) return d.message;
  return d === null || d === undefined ? "" : JSON.stringify(d);
}

export class ApiError extends Error {
  constructor(status, message, detail = null) { super(message); this.status = status; this.detail = detail; }
}

export async function api(method, path, body, type = "application/json") {
  const opts = { method, headers: {} };
  if (body !== undefined) {
    opts.headers["Content-Type"] = type;
    opts.body = typeof body === "string" ? body : JSON.stringify(body);
  }
  if (state.token && path.startsWith("/api/teacher")) opts.headers["X-Teacher-Token"] = state.token;
  let r;
  try {
    r = await fetch(path, opts);
  } catch {
    throw new ApiError(0, "The explorer server cannot be reached: is it still running?");
  }
  const text = await r.text();
  let data = null;
  try { data = text ? JSON.parse(text) : null; } catch { data = text; }
  if (!r.ok) {
    const raw = detailText(data && data.detail !== undefined ? data.detail : data);
    const generic = !raw || /^(Not Found|Method Not Allowed|Internal Server Error)$/.test(raw);
    const msg = generic || r.status >= 500 ? STATUS_TEXT[r.status] || `Request failed (${r.status}).` : plain(raw);
    throw new ApiError(r.status, msg, data && typeof data.detail === "object" ? data.detail : null);
  }
  return data;
}
