// The console's screens. Each view builds its DOM from API answers; no HTML is built from
// strings, so nothing a user typed can become markup.

import { api, followJob, imageUrl, text } from "./api.js";
import { linePlot } from "./plot.js";

export function h(tag, attributes = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attributes)) {
    if (value === undefined || value === null || value === false) continue;
    if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
    else if (key === "dataset") Object.assign(node.dataset, value);
    else node.setAttribute(key, value === true ? "" : value);
  }
  for (const child of children.flat()) if (child !== null && child !== undefined) node.append(child);
  return node;
}

// The skin models as the service describes them (GET /api/v1/models): every label and unit the
// console shows comes from there. Asked for once, and again after a failure.
let modelList = null;
export function models() {
  if (!modelList) modelList = api("GET", "/api/v1/models").catch((e) => { modelList = null; throw e; });
  return modelList;
}
export function modelOf(list, name) {
  return list.models.find((m) => m.name === name) || { name, params: [], derived: [], fit_quality: [] };
}
// A parameter, derived quantity or figure of fit quality (rmse, delta_e00_d65) of a model by
// name; its bare name when the model has none.
export function describe(model, name) {
  return model.params.find((p) => p.name === name) || model.derived.find((d) => d.name === name)
    || model.fit_quality.find((q) => q.name === name) || { name, label: name, unit: "" };
}
const unitNote = (unit) => (unit ? h("span", { class: "unit" }, unit) : null);

export const fmt = (v, digits = 4) => (v === null || v === undefined || !Number.isFinite(v) ? "–" : Number(v).toPrecision(digits));
export const when = (t) => (t ? new Date(t).toLocaleString() : "–");

function download(name, type, content) {
  const url = URL.createObjectURL(new Blob([content], { type }));
  const a = h("a", { href: url, download: name });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 1000);
}

function field(label, input) {
  return h("label", { class: "field" }, h("span", {}, label), input);
}

// ---- Sessions --------------------------------------------------------------------------

export async function sessionsView(root, query) {
  const [sites, standards, known] = await Promise.all([api("GET", "/api/v1/sites"), api("GET", "/api/v1/white-standards"), models()]);
  const siteOptions = (selected) => sites.sites.map((s) => h("option", { value: s.name, selected: s.name === selected }, s.name));

  const filter = h("form", { class: "filters", id: "session-filters" },
    field("Site", h("select", { name: "site" }, h("option", { value: "" }, "any"), siteOptions(query.get("site")))),
    field("State", h("select", { name: "state" }, ["", "open", "complete", "interrupted", "aborted"].map(
      (s) => h("option", { value: s, selected: s === (query.get("state") || "") }, s || "any")))),
    h("button", { type: "submit" }, "Filter"));
  filter.addEventListener("submit", (e) => {
    e.preventDefault();
    const q = new URLSearchParams();
    for (const [k, v] of new FormData(filter)) if (v) q.set(k, v);
    location.hash = `#/sessions?${q}`;
  });

  const q = new URLSearchParams();
  for (const key of ["site", "state", "cursor"]) if (query.get(key)) q.set(key, query.get(key));
  q.set("limit", "25");
  const page = await api("GET", `/api/v1/sessions?${q}`);
  const rows = page.sessions.map((s) => h("tr", { "data-session": s.id },
    h("td", {}, h("a", { href: `#/sessions/${s.id}` }, `#${s.id}`)), h("td", {}, s.subject), h("td", {}, s.site),
    h("td", {}, s.operator), h("td", {}, h("span", { class: `state ${s.state}` }, s.state)), h("td", {}, when(s.created_at))));
  const next = page.next_cursor
    ? h("a", { href: `#/sessions?${new URLSearchParams({ ...Object.fromEntries(q), cursor: page.next_cursor })}`, class: "button" }, "Older sessions")
    : null;

  const form = h("form", { class: "card", id: "new-session" },
    h("h2", {}, "New session"),
    field("Body site", h("select", { name: "site", required: true }, siteOptions("forearm"))),
    field("Subject pseudonym", h("input", { name: "subject", required: true, maxlength: 200, autocomplete: "off" })),
    field("Operator", h("input", { name: "operator", maxlength: 200 })),
    field("White standard", h("select", { name: "white_standard_id" },
      h("option", { value: "" }, "flat 0.99 (default)"),
      standards.white_standards.map((s) => h("option", { value: s.id }, `${s.name} (#${s.id})`)))),
    field("Notes", h("textarea", { name: "notes", rows: 2 })),
    field("Skin model", h("select", { name: "model" },
      known.models.map((m) => h("option", { value: m.name, selected: m.name === known.default }, m.name)))),
    h("button", { type: "submit", class: "primary" }, "Open session"),
    h("p", { class: "error", role: "alert" }));
  form.addEventListener("submit", async (e) => {
    e.preventDefault();
    const data = Object.fromEntries(new FormData(form));
    const body = { site: data.site, subject: data.subject, operator: data.operator, notes: data.notes, model: data.model };
    if (data.white_standard_id) body.white_standard_id = Number(data.white_standard_id);
    try {
      const session = await api("POST", "/api/v1/sessions", body);
      location.hash = `#/sessions/${session.id}`;
    } catch (err) {
      form.querySelector(".error").textContent = err.message;
    }
  });

  root.replaceChildren(
    h("section", { class: "columns" },
      h("div", { class: "card grow" }, h("h2", {}, "Sessions"), filter,
        h("table", { class: "list", id: "sessions" },
          h("thead", {}, h("tr", {}, ["Session", "Subject", "Site", "Operator", "State", "Opened"].map((t) => h("th", {}, t)))),
          h("tbody", {}, rows.length ? rows : h("tr", {}, h("td", { colspan: 6 }, "No sessions match.")))), next),
      form));
}

// ---- One session: acquisition ------------------------------------------------------------

// The meter's own settings, offered as the connected meter takes them (GET /api/v1/instrument's
// `capabilities`): none before a model is known, extended sensitivity and apertures only on a
// meter that has them. `values()` is what a measurement asks for.
function meterSettings(caps) {
  if (!caps) return { fields: [], values: () => ({}) };
  const averages = h("input", { type: "number", name: "averages", id: "averages", min: caps.averages.min, max: caps.averages.max, value: 1 });
  const sync = h("select", { name: "sync", id: "sync" },
    caps.sync.modes.map((mode) => h("option", { value: mode }, mode === "frequency" ? `frequency (${caps.sync.min_hz}–${caps.sync.max_hz} Hz)` : mode)));
  const hz = h("input", { type: "number", name: "sync_hz", id: "sync-hz", min: caps.sync.min_hz, max: caps.sync.max_hz,
    step: caps.sync.whole_hz ? 1 : "any", value: 60, disabled: true });
  sync.addEventListener("change", () => { hz.disabled = sync.value !== "frequency"; });
  const extended = caps.extended_sensitivity ? h("input", { type: "checkbox", name: "extended_sensitivity", id: "extended-sensitivity" }) : null;
  const aperture = (caps.apertures || []).length
    ? h("select", { name: "aperture", id: "aperture" }, h("option", { value: "" }, "as set on the meter"),
      caps.apertures.map((name) => h("option", { value: name }, name)))
    : null;
  const fields = [field("Meter averages", averages), field("Sync", sync), field("Sync Hz", hz),
    extended ? field("Extended sensitivity", extended) : null, aperture ? field("Aperture", aperture) : null];
  const values = () => {
    const asked = { averages: Number(averages.value) || 1, sync: sync.value === "frequency" ? Number(hz.value) : sync.value };
    if (extended?.checked) asked.extended_sensitivity = true;
    if (aperture?.value) asked.aperture = aperture.value;
    return asked;
  };
  return { fields: fields.filter(Boolean), values };
}

export async function sessionView(root, id) {
  const [session, known, instrument] = await Promise.all([api("GET", `/api/v1/sessions/${id}`), models(),
    api("GET", "/api/v1/instrument").catch(() => null)]);
  const caps = instrument?.capabilities || null;
  const settings = meterSettings(caps);
  const model = modelOf(known, session.model);
  const [melanin, rmse, deltaE] = ["melanin", "rmse", "delta_e00_d65"].map((name) => describe(model, name));
  const open = session.state === "open";
  const fitsByMeasurement = new Map(session.fits.map((f) => [f.measurement_id, f]));

  const job = h("div", { class: "job", id: "job", "aria-live": "polite" });
  const count = h("input", { type: "number", name: "count", min: 1, max: 100, value: 1, id: "count" });
  const label = h("input", { name: "label", maxlength: 200, id: "label", autocomplete: "off" });
  const longest = caps ? caps.integration_ms.max_extended ?? caps.integration_ms.max : 120000;
  const integration = h("input", { type: "number", name: "integration_ms", min: 0, max: longest, value: 0, id: "integration" });
  const measure = (kind) => startJob(job, id, { kind, count: Number(count.value) || 1, label: label.value,
                                                integration_ms: Number(integration.value) || 0, ...settings.values() });
  const acquire = h("div", { class: "card acquire" },
    h("h2", {}, "Acquisition"),
    open ? h("div", { class: "row" },
      h("button", { id: "measure-white", onclick: () => measure("white"), title: "Measure the white standard (W)" }, "Measure white ", h("kbd", {}, "W")),
      h("button", { id: "measure-sample", class: "primary", onclick: () => measure("sample"), title: "Measure the skin (S)" },
        "Measure sample ", h("kbd", {}, "S")),
      field("Readings averaged", count), field("Label", label), field("Integration ms (0 adaptive)", integration),
      ...settings.fields)
      : h("p", {}, `This session is ${session.state}; it takes no more measurements.`),
    job);

  const rows = session.measurements.map((m) => {
    const fit = fitsByMeasurement.get(m.id);
    return h("tr", { "data-measurement": m.id },
      h("td", {}, h("a", { href: `#/measurements/${m.id}` }, `#${m.id}`)), h("td", {}, m.kind), h("td", {}, m.label || ""),
      h("td", {}, `${m.quality.code} ${m.quality.text}`), h("td", {}, fit ? fmt(fit.params.melanin, 3) : "–"),
      h("td", {}, fit ? fmt(fit.rmse, 3) : "–"), h("td", {}, fit ? fmt(fit.delta_e00_d65, 3) : "–"),
      h("td", { class: "warn" }, (m.warnings || []).join("; ")), h("td", {}, when(m.created_at)));
  });

  const exportCsv = async () => download(`session-${id}.csv`, "text/csv", await text(`/api/v1/sessions/${id}/export.csv`));
  const exportJson = async () =>
    download(`session-${id}.json`, "application/json", JSON.stringify(await api("GET", `/api/v1/sessions/${id}`), null, 2));
  const close = async () => {
    await api("PATCH", `/api/v1/sessions/${id}`, { close: true });
    location.reload();
  };

  root.replaceChildren(
    h("section", { class: "card" },
      h("h2", {}, `Session #${session.id}: ${session.subject}, ${session.site}`),
      h("p", { class: "meta" }, `Operator ${session.operator || "–"} · model ${session.model} · white standard ${session.white_standard_id ?? "flat 0.99"} · `,
        h("span", { class: `state ${session.state}` }, session.state), ` · opened ${when(session.created_at)}`),
      session.notes ? h("p", {}, session.notes) : null,
      h("div", { class: "row" },
        h("button", { id: "export-csv", onclick: exportCsv }, "Export CSV"),
        h("button", { id: "export-json", onclick: exportJson }, "Export JSON"),
        open ? h("button", { id: "close-session", onclick: close }, "Close session") : null)),
    acquire,
    h("section", { class: "card" }, h("h2", {}, "Measurements"),
      h("table", { class: "list", id: "measurements" },
        h("thead", {}, h("tr", {}, ["Measurement", "Kind", "Label", "Quality",
          ...[melanin, rmse, deltaE].map((q) => [q.label, unitNote(q.unit)]), "Warnings", "Time"]
          .map((t) => h("th", {}, t)))),
        h("tbody", {}, rows.length ? rows : h("tr", {}, h("td", { colspan: 9 }, "Nothing measured yet: start with the white standard."))))));

  return open ? { keys: { w: () => measure("white"), s: () => measure("sample") } } : {};
}

// Submits a measurement and shows its job live until it ends; then the session reloads.
async function startJob(box, sessionId, body) {
  const controller = new AbortController();
  const bar = h("progress", { max: 1, value: 0, id: "job-progress" });
  const status = h("span", { class: "job-status", id: "job-status" }, "submitting…");
  const warnings = h("ul", { class: "warn", id: "job-warnings" });
  let jobId = null;
  const cancel = h("button", { id: "cancel-job", title: "Cancel (Esc)", onclick: async () => {
    if (jobId !== null) await api("DELETE", `/api/v1/jobs/${jobId}`).catch((e) => { status.textContent = e.message; });
  } }, "Cancel ", h("kbd", {}, "Esc"));
  box.replaceChildren(h("div", { class: "row" }, bar, status, cancel), warnings);
  delete box.dataset.state;
  delete box.dataset.job;
  box.cancel = () => cancel.click();
  try {
    const accepted = await api("POST", `/api/v1/sessions/${sessionId}/measurements`, body);
    jobId = accepted.job_id;
    box.dataset.job = jobId;
    const final = await followJob(jobId, (job) => showJob(job, bar, status, warnings), controller.signal);
    cancel.disabled = true;
    box.dataset.state = final.state;
    // Show the new measurement in the list, unless the user has moved on meanwhile (another
    // screen, or another job started here).
    const screen = location.hash;
    const refresh = () => {
      if (location.hash === screen && box.isConnected && box.dataset.job === String(jobId)) window.dispatchEvent(new Event("hashchange"));
    };
    if (final.state === "succeeded") setTimeout(refresh, 600);
  } catch (err) {
    status.textContent = err.message;
    box.dataset.state = "refused";
    cancel.disabled = true;
  }
}

function showJob(job, bar, status, warnings) {
  const p = job.progress || {};
  const total = p.readings_total || job.request?.count || 1;
  const done = p.readings_done ?? (job.state === "succeeded" ? total : 0);
  bar.value = job.state === "succeeded" ? 1 : p.fraction ?? done / total;
  let text = `job #${job.id}: ${job.state}`;
  if (job.state === "queued" && job.position) text += `, position ${job.position} in the queue`;
  if (job.state === "running") text += `, ${p.phase || "measuring"}, reading ${done} of ${total}`;
  if (job.error) text += ` (${job.error.code}: ${job.error.message})`;
  if (job.state === "succeeded" && job.result?.measurement_id)
    text += `: measurement #${job.result.measurement_id}${job.result.fit_id ? `, fit #${job.result.fit_id}` : ""}`;
  status.textContent = text;
  status.className = `job-status ${job.state}`;
  warnings.replaceChildren(...(job.result?.warnings || []).map((w) => h("li", {}, w)));
}

// ---- One measurement: spectra, fit, colour, render -----------------------------------------

export async function measurementView(root, id) {
  const [m, known] = await Promise.all([api("GET", `/api/v1/measurements/${id}`), models()]);
  const fit = m.fit_id ? await api("GET", `/api/v1/fits/${m.fit_id}`) : null;
  const model = fit ? modelOf(known, fit.model) : null;
  const radiance = linePlot({ title: `Radiance (${m.units})`, xLabel: "wavelength (nm)", yLabel: "radiance",
    series: [{ name: "radiance", kind: "radiance", x: m.radiance.wavelength_nm, y: m.radiance.values }] });
  radiance.id = "plot-radiance";
  const parts = [h("section", { class: "card" },
    h("h2", {}, `Measurement #${m.id}: ${m.kind}${m.label ? ` “${m.label}”` : ""}`),
    h("p", { class: "meta" }, h("a", { href: `#/sessions/${m.session_id}` }, `session #${m.session_id}`),
      ` · quality ${m.quality.code} ${m.quality.text} · ${m.reading_count} reading(s) · ${when(m.created_at)}`),
    settingsLine(m.provenance?.settings),
    (m.warnings || []).length ? h("ul", { class: "warn", id: "measurement-warnings" }, m.warnings.map((w) => h("li", {}, w))) : null,
    h("div", { class: "row" },
      h("button", { id: "export-measurement", onclick: () => download(`measurement-${id}.json`, "application/json", JSON.stringify({ measurement: m, fit }, null, 2)) }, "Export JSON")),
    radiance)];

  if (m.reflectance) {
    const series = [{ name: "measured", kind: "measured", x: m.reflectance.wavelength_nm, y: m.reflectance.values }];
    if (fit) series.push({ name: "fitted", kind: "fitted", x: fit.wavelength_nm, y: fit.fitted });
    const reflectance = linePlot({ title: "Reflectance", xLabel: "wavelength (nm)", yLabel: "reflectance", series });
    reflectance.id = "plot-reflectance";
    const card = h("section", { class: "card" }, reflectance);
    if (fit) {
      const residuals = linePlot({ title: "Residuals (measured − fitted)", xLabel: "wavelength (nm)", yLabel: "residual", zeroLine: true,
        height: 200, series: [{ name: "residual", kind: "residual", x: fit.wavelength_nm, y: fit.measured.map((v, i) => v - fit.fitted[i]) }] });
      residuals.id = "plot-residuals";
      card.append(residuals);
    }
    parts.push(card);
  }
  parts.push(h("section", { class: "columns" }, fit ? fitTable(fit, model) : null, m.colour ? swatches(m.colour) : null));
  if (fit) parts.push(renderCard(fit, model));
  root.replaceChildren(...parts);
}

// How the meter measured (the stored provenance); nothing for an import, which was not measured here.
function settingsLine(settings) {
  if (!settings || settings.count === undefined) return null;
  const used = (settings.exposure_used_ms || []).map((ms) => (ms === null ? "unknown" : `${ms} ms`)).join(", ");
  const parts = [settings.integration_ms ? `exposure ${settings.integration_ms} ms` : "adaptive exposure",
    used ? `used ${used}` : null, `${settings.averages ?? 1} meter average(s)`, `sync ${settings.sync ?? "off"}`,
    settings.extended_sensitivity ? "extended sensitivity" : null, settings.aperture ? `aperture ${settings.aperture}` : null];
  return h("p", { class: "meta", id: "measurement-settings" }, parts.filter(Boolean).join(" · "));
}

// A parameter the spectrum did not determine shows "n.d." and why, never a number that looks known.
function determined(fit, key) {
  const d = fit.determination && fit.determination[key];
  return !d || d.determined;
}

function paramRow(fit, spec) {
  const key = spec.name;
  const d = fit.determination && fit.determination[key];
  const value = determined(fit, key)
    ? [h("td", { class: "value" }, fmt(fit.params[key])), h("td", {}, "±"), h("td", { class: "se" }, fmt(fit.stderr[key], 2))]
    : [h("td", { class: "value nd", title: `not determined: ${d.reason}${d.correlated_with ? " with " + d.correlated_with : ""}` }, "n.d."),
       h("td", {}), h("td", { class: "se" }, d.reason.replace("_", " "))];
  return h("tr", { "data-param": key }, h("th", { title: spec.source || "" }, spec.label), ...value, h("td", { class: "unit" }, spec.unit));
}

// A quantity derived from the parameters, unless the model fits it as a parameter itself.
function derivedRow(fit, spec) {
  const key = spec.name;
  const q = fit.derived && fit.derived[key];
  if (!q || key in fit.params) return null;
  const value = q.determined ? [h("td", { class: "value" }, fmt(q.value, 3)), h("td", {}, "±"), h("td", { class: "se" }, fmt(q.stderr, 2))]
    : [h("td", { class: "value nd" }, "n.d."), h("td", {}), h("td", { class: "se" }, q.reason.replace("_", " "))];
  return h("tr", { "data-param": key }, h("th", {}, `${spec.label} (derived)`), ...value, h("td", { class: "unit" }, spec.unit));
}

// How well the fit matches its spectrum: a figure the fit gives, in its unit.
function qualityRow(fit, spec) {
  return h("tr", { "data-param": spec.name }, h("th", {}, spec.label), h("td", { class: "value" }, fmt(fit[spec.name], 3)),
    h("td", {}), h("td", {}), h("td", { class: "unit" }, spec.unit));
}

// A descriptor of the measured spectrum's skin tone (ITA°, its class, the melanin and erythema
// indices), in its unit; a class is a name, not a number.
function skinToneRow(tone, spec) {
  const v = tone[spec.name];
  const shown = typeof v === "string" ? v.replaceAll("_", " ") : fmt(v, 3);
  return h("tr", { "data-param": spec.name }, h("th", {}, spec.label), h("td", { class: "value" }, shown),
    h("td", {}), h("td", {}), h("td", { class: "unit" }, spec.unit));
}

// The fit's parameters in its model's order (any the model does not describe after them).
function fitTable(fit, model) {
  const own = model.params.map((p) => p.name);
  const keys = [...own.filter((k) => k in fit.params), ...Object.keys(fit.params).filter((k) => !own.includes(k))];
  return h("div", { class: "card" }, h("h2", {}, `Fit #${fit.id}, ${fit.site}, model ${fit.model}`),
    h("table", { class: "params", id: "fit-params" },
      h("tbody", {},
        keys.map((key) => paramRow(fit, describe(model, key))),
        model.derived.map((d) => derivedRow(fit, d)),
        ["rmse", "delta_e00_d65"].map((key) => qualityRow(fit, describe(model, key))),
        fit.skin_tone ? (model.skin_tone || []).map((spec) => skinToneRow(fit.skin_tone, spec)) : null,
        h("tr", {}, h("th", {}, "Converged"), h("td", {}, fit.converged ? `yes, ${fit.iterations} iterations` : "no"),
          h("td", {}), h("td", {}), h("td", { class: "unit" }, fit.termination ? fit.termination.replaceAll("_", " ") : "")))),
    fit.note ? h("p", { class: "meta" }, fit.note) : null);
}

function swatches(colour) {
  return h("div", { class: "card" }, h("h2", {}, "Colour"),
    h("div", { class: "swatches" }, ["D65", "A"].filter((k) => colour[k]).map((k) => {
      const [r, g, b] = colour[k].srgb;
      const [L, a, bb] = colour[k].lab;
      const chip = h("div", { class: "chip", "data-illuminant": k, "data-srgb": `${r},${g},${b}` });
      chip.style.background = `rgb(${r}, ${g}, ${b})`;
      return h("figure", {}, chip, h("figcaption", {}, `${k === "A" ? "A (lamp)" : "D65 (daylight)"}: L* ${fmt(L, 3)}, a* ${fmt(a, 3)}, b* ${fmt(bb, 3)}`));
    })));
}

// A slider for one of the fit's own parameters (docs/web-console.md): an amount is scaled, ×0 to
// ×4 (render query scale_NAME); anything else, a saturation or a reflectance, and an amount the
// fit found none of (a multiple of none is none), is set to a value within its plausible range
// widened to hold the fitted value (query NAME). Only a moved slider goes into the query, so the
// untouched image is the fit's own.
function paramSlider(fit, spec) {
  const fitted = fit.params[spec.name];
  if (!Number.isFinite(fitted)) return null;
  const scale = spec.absorber && fitted > 0;
  const id = `${scale ? "scale" : "set"}-${spec.name}`;
  let range = { min: 0, max: 4, step: 0.25, value: 1 };
  if (!scale) {
    const low = Math.min(spec.bounds[0], fitted), high = Math.max(spec.bounds[1], fitted);
    const step = 10 ** Math.floor(Math.log10((high - low) / 100 || 1e-3));
    const snap = (v) => Number(v.toPrecision(12));
    range = { min: Math.max(spec.domain[0], snap(Math.floor(low / step) * step)),
              max: Math.min(spec.domain[1], snap(Math.ceil(high / step) * step)), step, value: fitted };
  }
  const input = h("input", { type: "range", id, ...range, "aria-label": `${spec.label}${scale ? " scale" : ""}`, "data-param": spec.name });
  const start = input.value;
  const shown = h("output", { for: id });
  const show = () => {
    if (scale) shown.textContent = `×${input.value} → ${fmt(fitted * Number(input.value), 3)}`;
    else shown.textContent = fmt(input.value === start ? fitted : Number(input.value), 3);
  };
  for (const event of ["input", "change"]) input.addEventListener(event, show);
  show();
  return { input, start, show, query: scale ? `scale_${spec.name}` : spec.name,
           row: field([spec.label, " ", unitNote(`(${spec.unit})`)], h("span", { class: "slider" }, input, shown)) };
}

function renderCard(fit, model) {
  const img = h("img", { id: "render", alt: "the fitted skin rendered on a hand", width: 384, height: 384 });
  const note = h("p", { class: "meta", id: "render-status", "aria-live": "polite" });
  const illuminant = h("select", { id: "render-illuminant" }, h("option", { value: "D65" }, "D65"), h("option", { value: "A" }, "A"));
  const sliders = model.params.map((spec) => paramSlider(fit, spec)).filter(Boolean);
  let timer = null, controller = null, url = null;
  const draw = () => {
    clearTimeout(timer);
    timer = setTimeout(async () => {
      if (controller) controller.abort();
      controller = new AbortController();
      const q = new URLSearchParams({ illuminant: illuminant.value, size: "384x384" });
      for (const s of sliders) if (s.input.value !== s.start) q.set(s.query, s.input.value);
      note.textContent = "rendering…";
      try {
        const next = await imageUrl(`/api/v1/fits/${fit.id}/render.png?${q}`, controller.signal);
        if (url) URL.revokeObjectURL(url);
        url = next;
        img.src = url;
        img.dataset.query = q.toString();
        note.textContent = "";
      } catch (e) {
        if (e.name !== "AbortError") note.textContent = `no render: ${e.message}`;
      }
    }, 200);
  };
  const reset = h("button", { type: "button", id: "render-reset", onclick: () => {
    for (const s of sliders) { s.input.value = s.start; s.show(); }
    draw();
  } }, "Fitted values");
  illuminant.addEventListener("change", draw);
  for (const s of sliders) s.input.addEventListener("change", draw);
  draw();
  return h("section", { class: "card render" }, h("h2", {}, "Rendered skin"),
    h("div", { class: "columns" }, img,
      h("div", { class: "controls", id: "render-controls" }, field("Illuminant", illuminant), sliders.map((s) => s.row), reset, note)));
}
