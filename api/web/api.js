// The console's only door to skinspecd: JSON requests with the user's token, a job's event
// stream, and images fetched with the token (an <img src> cannot send one).

const TOKEN_KEY = "skinspec.token";

export class ApiError extends Error {
  constructor(status, code, message) {
    super(message);
    this.status = status;
    this.code = code;
  }
}

export function setToken(token) {
  if (token) sessionStorage.setItem(TOKEN_KEY, token);
  else sessionStorage.removeItem(TOKEN_KEY);
}

function headers(extra = {}) {
  const h = { ...extra };
  const token = sessionStorage.getItem(TOKEN_KEY);
  if (token) h.Authorization = `Bearer ${token}`;
  return h;
}

async function failure(response) {
  let code = "http_" + response.status;
  let message = `${response.status} ${response.statusText}`;
  try {
    const body = await response.json();
    if (body && body.error) ({ code, message } = body.error);
  } catch {
    // not JSON: keep the status line
  }
  return new ApiError(response.status, code, message);
}

export async function api(method, path, body) {
  const init = { method, headers: headers(body === undefined ? {} : { "Content-Type": "application/json" }) };
  if (body !== undefined) init.body = JSON.stringify(body);
  let response;
  try {
    response = await fetch(path, init);
  } catch (e) {
    throw new ApiError(0, "unreachable", `skinspecd cannot be reached (${e.message})`);
  }
  if (!response.ok) throw await failure(response);
  return response.json();
}

// An image route as an object URL; the caller revokes it when replacing the image.
export async function imageUrl(path, signal) {
  const response = await fetch(path, { headers: headers(), signal });
  if (!response.ok) throw await failure(response);
  return URL.createObjectURL(await response.blob());
}

// A binary download (a map's answer cube) through the token, as an ArrayBuffer.
export async function bytes(path) {
  const response = await fetch(path, { headers: headers() });
  if (!response.ok) throw await failure(response);
  return response.arrayBuffer();
}

// A text download (CSV) through the token.
export async function text(path) {
  const response = await fetch(path, { headers: headers() });
  if (!response.ok) throw await failure(response);
  return response.text();
}

const FINISHED = new Set(["succeeded", "failed", "cancelled"]);

// Follows a job until it ends, calling onUpdate with each new state of the job. Reads the
// Server-Sent Events of /api/v1/jobs/{id}/events through fetch (EventSource cannot send the
// token); falls back to asking every 300 ms when the stream is not available.
export async function followJob(jobId, onUpdate, signal) {
  let last = null;
  const update = (job) => {
    last = job;
    onUpdate(job);
  };
  try {
    const response = await fetch(`/api/v1/jobs/${jobId}/events`, { headers: headers({ Accept: "text/event-stream" }), signal });
    if (response.ok && response.body) {
      await readEvents(response.body, (event) => {
        if (event.data) update(JSON.parse(event.data));
      });
    }
  } catch (e) {
    if (signal && signal.aborted) throw e;
  }
  while (!last || !FINISHED.has(last.state)) {
    if (last) await new Promise((resolve) => setTimeout(resolve, 300));
    if (signal && signal.aborted) throw new DOMException("aborted", "AbortError");
    update(await api("GET", `/api/v1/jobs/${jobId}`));
  }
  return last;
}

// Server-Sent Events framing: fields up to a blank line make one event.
async function readEvents(stream, onEvent) {
  const reader = stream.pipeThrough(new TextDecoderStream()).getReader();
  let buffer = "";
  for (;;) {
    const { value, done } = await reader.read();
    if (done) break;
    buffer += value.replace(/\r\n?/g, "\n");
    let end;
    while ((end = buffer.indexOf("\n\n")) >= 0) {
      const block = buffer.slice(0, end);
      buffer = buffer.slice(end + 2);
      const event = { event: "message", data: "", id: null };
      for (const line of block.split("\n")) {
        if (line.startsWith(":")) continue;
        const colon = line.indexOf(":");
        const field = colon < 0 ? line : line.slice(0, colon);
        const content = colon < 0 ? "" : line.slice(colon + 1).replace(/^ /, "");
        if (field === "data") event.data += (event.data ? "\n" : "") + content;
        else if (field === "event") event.event = content;
        else if (field === "id") event.id = content;
      }
      if (event.data) onEvent(event);
    }
  }
}
