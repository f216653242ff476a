// The console's frame: the instrument status kept live, the token, the screen for the address
// after '#', and the keyboard shortcuts of the screen shown.

import { api, setToken } from "./api.js";
import { h, measurementView, sessionView, sessionsView } from "./views.js";
import { mapView, mapsView } from "./maps.js";

const main = document.getElementById("main");
const statusBox = document.getElementById("instrument");
let screenKeys = {};

async function showInstrument() {
  try {
    const s = await api("GET", "/api/v1/instrument");
    const parts = [h("span", { class: `pill ${s.state}`, id: "instrument-state" }, s.state)];
    if (s.port || s.device) parts.push(h("span", { id: "instrument-port" }, s.port || s.device));
    if (s.reported_model) parts.push(h("span", { id: "instrument-model", title: s.family ? `family ${s.family}` : "" }, s.reported_model));
    if (s.serial_number) parts.push(h("span", { id: "instrument-serial" }, `S/N ${s.serial_number}`));
    if (s.queued) parts.push(h("span", {}, `${s.queued} queued`));
    if (s.last_error && s.state !== "connected") parts.push(h("span", { class: "warn" }, s.last_error));
    statusBox.replaceChildren(...parts);
  } catch (e) {
    statusBox.replaceChildren(h("span", { class: "pill lost", id: "instrument-state" }, "unreachable"), h("span", {}, e.message));
    if (e.status === 401) askForToken();
  }
}

function askForToken() {
  if (document.getElementById("token-form")) return;
  const input = h("input", { type: "password", name: "token", autocomplete: "off", "aria-label": "access token" });
  const form = h("form", { id: "token-form", class: "card" }, h("h2", {}, "This skinspecd needs an access token"),
    input, h("button", { type: "submit", class: "primary" }, "Use token"));
  form.addEventListener("submit", (e) => {
    e.preventDefault();
    setToken(input.value.trim());
    form.remove();
    route();
  });
  main.before(form);
  input.focus();
}

// Screens are built off-page and shown only if no newer navigation started meanwhile: two
// quick hash changes must not leave the slower, older screen on top of the newer one.
let latestRoute = 0;

async function route() {
  const ticket = ++latestRoute;
  const [path, queryString] = location.hash.replace(/^#/, "").split("?");
  const query = new URLSearchParams(queryString || "");
  const parts = (path || "/sessions").split("/").filter(Boolean);
  document.querySelectorAll("nav a").forEach((a) => a.classList.toggle("current", location.hash.startsWith(a.getAttribute("href"))));
  main.setAttribute("aria-busy", "true");
  const screen = document.createElement("div");
  let keys = {};
  try {
    if (parts[0] === "sessions" && parts[1]) keys = (await sessionView(screen, Number(parts[1]))).keys || {};
    else if (parts[0] === "measurements" && parts[1]) await measurementView(screen, Number(parts[1]));
    else if (parts[0] === "maps" && parts[1]) await mapView(screen, Number(parts[1]));
    else if (parts[0] === "maps") await mapsView(screen);
    else await sessionsView(screen, query);
  } catch (e) {
    screen.replaceChildren(h("section", { class: "card error", role: "alert" }, h("h2", {}, "Cannot show this"), h("p", {}, e.message)));
    if (e.status === 401) askForToken();
  }
  if (ticket !== latestRoute) return;
  screenKeys = keys;
  main.replaceChildren(...screen.childNodes);
  main.setAttribute("aria-busy", "false");
  const heading = main.querySelector("h2");
  if (heading) { heading.tabIndex = -1; heading.focus({ preventScroll: true }); }
}

document.addEventListener("keydown", (e) => {
  const typing = /^(INPUT|TEXTAREA|SELECT)$/.test(e.target.tagName);
  if (e.key === "Escape") { document.getElementById("cancel-job")?.click(); return; }
  if (typing || e.ctrlKey || e.metaKey || e.altKey) return;
  const action = screenKeys[e.key.toLowerCase()];
  if (action) { e.preventDefault(); action(); }
});

window.addEventListener("hashchange", route);
route();
showInstrument();
setInterval(showInstrument, 2000);
