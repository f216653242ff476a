// The Maps screens: the stored skin maps, and one map drawn from its answer cube in the pictures'
// colour map (served by the map itself), with the value under the pointer, a pixel's measured
// and fitted spectra on a click, and the statistics of a dragged rectangle.

import { api, bytes } from "./api.js";
import { linePlot } from "./plot.js";
import { describe, fmt, h, modelOf, models, when } from "./views.js";

export async function mapsView(root) {
  const list = await api("GET", "/api/v1/maps?limit=200");
  const rows = list.maps.map((m) => h("tr", { "data-map": m.id },
    h("td", {}, h("a", { href: `#/maps/${m.id}` }, `#${m.id}`)), h("td", {}, m.name),
    h("td", {}, m.session_id ? h("a", { href: `#/sessions/${m.session_id}` }, `#${m.session_id}`) : "–"),
    h("td", {}, `${m.summary.samples} × ${m.summary.lines}`), h("td", {}, String(m.summary.pixels.skin)),
    h("td", {}, `${m.summary.model}, ${m.summary.site}`), h("td", {}, when(m.created_at))));
  root.replaceChildren(h("section", { class: "card" }, h("h2", {}, "Skin maps"),
    h("table", { class: "list", id: "maps" },
      h("thead", {}, h("tr", {}, ["Map", "Name", "Session", "Size", "Skin pixels", "Model", "Made"].map((t) => h("th", {}, t)))),
      h("tbody", {}, rows.length ? rows : h("tr", {}, h("td", { colspan: 7 }, "No maps yet: POST /api/v1/maps or `skinspec map`."))))));
}

// The answer cube: float32, little-endian, band-interleaved by line (GET /api/v1/maps/{id}/cube).
function answerCube(map, buffer) {
  const lines = map.summary.lines, samples = map.summary.samples, bands = map.bands.length;
  const view = new DataView(buffer);
  const at = (x, y, band) => view.getFloat32(((y * bands + band) * samples + x) * 4, true);
  return { lines, samples, bands, at, mask: (x, y) => at(x, y, bands - 1) };
}

const mixed = (hexes) => hexes.map((c) => [1, 3, 5].map((i) => parseInt(c.slice(i, i + 2), 16)));

// The parameter's band of the cube as an image, as the PNG draws it.
function paint(canvas, cube, band, range, colourMap) {
  const ctx = canvas.getContext("2d");
  const image = ctx.createImageData(cube.samples, cube.lines);
  const colours = mixed(colourMap.colours);
  const [nd] = mixed([colourMap.not_determined]), [masked] = mixed([colourMap.not_skin]);
  const [lo, hi] = range;
  for (let y = 0; y < cube.lines; ++y)
    for (let x = 0; x < cube.samples; ++x) {
      const v = cube.at(x, y, band);
      let c = masked;
      if (cube.mask(x, y) === 0) {
        const t = hi > lo ? Math.min(1, Math.max(0, (v - lo) / (hi - lo))) : 0.5;
        c = Number.isNaN(v) ? nd : colours[Math.round(t * (colours.length - 1))];
      }
      image.data.set([...c, 255], (y * cube.samples + x) * 4);
    }
  ctx.putImageData(image, 0, 0);
}

// Set through the style object: the console's Content-Security-Policy refuses style attributes.
function swatch(colour) {
  const box = h("span", { class: "swatch" });
  box.style.background = colour;
  return box;
}

function colourBar(range, unit, colourMap) {
  const bar = h("canvas", { width: 24, height: 256, class: "bar-scale", "aria-hidden": "true" });
  const ctx = bar.getContext("2d");
  colourMap.colours.forEach((c, i) => {
    ctx.fillStyle = c;
    ctx.fillRect(0, 255 - i, 24, 1);
  });
  const [lo, hi] = range;
  const label = (v, cls) => h("span", { class: cls }, fmt(v, 3));
  return h("figure", { id: "colour-bar", class: "colour-bar", dataset: { low: String(lo), high: String(hi) } },
    h("div", { class: "bar" }, bar,
      h("div", { class: "bar-labels" }, label(hi, "bar-high"), label((lo + hi) / 2, "bar-mid"), label(lo, "bar-low"))),
    h("figcaption", {}, unit || ""),
    h("p", { class: "swatch-line" }, swatch(colourMap.not_determined), " n.d. ", swatch(colourMap.not_skin), " not skin"));
}

// Mean, SD, median, least and most of the determined values, and the counts, over a rectangle.
function regionStatistics(cube, band, [x0, y0, x1, y1]) {
  const values = [];
  let pixels = 0, skin = 0;
  for (let y = y0; y <= y1; ++y)
    for (let x = x0; x <= x1; ++x) {
      ++pixels;
      if (cube.mask(x, y) !== 0) continue;
      ++skin;
      const v = cube.at(x, y, band);
      if (!Number.isNaN(v)) values.push(v);
    }
  values.sort((a, b) => a - b);
  const n = values.length;
  const mean = n ? values.reduce((s, v) => s + v, 0) / n : NaN;
  const sd = n > 1 ? Math.sqrt(values.reduce((s, v) => s + (v - mean) ** 2, 0) / (n - 1)) : NaN;
  const median = n ? (n % 2 ? values[(n - 1) / 2] : (values[n / 2 - 1] + values[n / 2]) / 2) : NaN;
  return { pixels, skin, determined: n, mean, sd, median, min: n ? values[0] : NaN, max: n ? values[n - 1] : NaN };
}

export async function mapView(root, id) {
  const [map, known] = await Promise.all([api("GET", `/api/v1/maps/${id}`), models()]);
  const cube = answerCube(map, await bytes(map.links.cube));
  const model = modelOf(known, map.summary.model);
  const parameters = Object.keys(map.links.pictures);
  const bandOf = (name) => map.bands.findIndex((b) => b.name === name);
  const canvas = h("canvas", { id: "map-canvas", class: "map-canvas", width: cube.samples, height: cube.lines,
    "aria-label": "the map: point for a pixel's values, click for its spectra, drag for a region's statistics" });
  const zoom = Math.max(1, Math.floor(512 / Math.max(cube.samples, cube.lines)));
  canvas.style.width = `${cube.samples * zoom}px`;
  canvas.style.height = `${cube.lines * zoom}px`;
  const selection = h("div", { class: "selection", id: "map-selection", hidden: true });
  const hover = h("p", { id: "map-hover", class: "readout", "aria-live": "polite" }, "Point at the map.");
  const region = h("div", { id: "map-region" });
  const pixelBox = h("div", { id: "map-pixel" }, h("p", { class: "meta" }, "Click a pixel for its measured and fitted spectra."));
  const barBox = h("div", {});
  // Melanin first, the quantity a skin map is most often made for.
  let parameter = parameters.includes("melanin") ? "melanin" : parameters[0];
  const chooser = h("select", { id: "map-parameter", "aria-label": "parameter" },
    parameters.map((p) => h("option", { value: p, selected: p === parameter }, describe(model, p).label || p)));

  let rect = null;
  const show = () => {
    const spec = describe(model, parameter);
    const range = map.summary.parameters[parameter].picture_range.map((v) => (v === null ? NaN : v));
    paint(canvas, cube, bandOf(parameter), range, map.colour_map);
    barBox.replaceChildren(colourBar(range, spec.unit, map.colour_map));
    if (rect) showRegion();
  };
  const pixelAt = (e) => {
    const box = canvas.getBoundingClientRect();
    const x = Math.floor(((e.clientX - box.left) / box.width) * cube.samples);
    const y = Math.floor(((e.clientY - box.top) / box.height) * cube.lines);
    return [Math.min(cube.samples - 1, Math.max(0, x)), Math.min(cube.lines - 1, Math.max(0, y))];
  };
  const describePixel = ([x, y]) => {
    const spec = describe(model, parameter);
    const mask = cube.mask(x, y);
    const band = bandOf(parameter);
    const v = cube.at(x, y, band), se = cube.at(x, y, band + 1);
    let text, value;
    if (mask !== 0) [text, value] = [map.mask_reasons[mask].replace("_", " "), map.mask_reasons[mask]];
    else if (Number.isNaN(v)) [text, value] = ["n.d. (not determined by the spectrum)", "nd"];
    else [text, value] = [`${fmt(v)} ± ${fmt(se, 2)} ${spec.unit || ""}`, String(v)];
    hover.dataset.x = x;
    hover.dataset.y = y;
    hover.dataset.value = value;
    hover.textContent = `pixel (${x}, ${y}) · ${spec.label || parameter}: ${text}`;
  };
  const showRegion = () => {
    const s = regionStatistics(cube, bandOf(parameter), rect);
    const spec = describe(model, parameter);
    region.replaceChildren(h("table", { class: "params", id: "region-table", dataset: { x0: rect[0], y0: rect[1], x1: rect[2], y1: rect[3],
      mean: String(s.mean), sd: String(s.sd), median: String(s.median), min: String(s.min), max: String(s.max), determined: s.determined, skin: s.skin } },
      h("caption", {}, `Region x ${rect[0]}–${rect[2]}, y ${rect[1]}–${rect[3]}: ${spec.label || parameter}`),
      [["pixels", s.pixels], ["skin", s.skin], ["determined", s.determined], ["mean", fmt(s.mean)], ["SD", fmt(s.sd)],
        ["median", fmt(s.median)], ["least", fmt(s.min)], ["most", fmt(s.max)]]
        .map(([k, v]) => h("tr", {}, h("th", {}, k), h("td", { class: "value" }, String(v))))));
    const box = canvas.getBoundingClientRect(), scale = box.width / cube.samples;
    Object.assign(selection.style, { left: `${rect[0] * scale}px`, top: `${rect[1] * scale}px`,
      width: `${(rect[2] - rect[0] + 1) * scale}px`, height: `${(rect[3] - rect[1] + 1) * scale}px` });
    selection.hidden = false;
  };
  const showPixel = async ([x, y]) => {
    const pixel = await api("GET", `/api/v1/maps/${id}/pixel?x=${x}&y=${y}`);
    const series = [{ name: "measured", kind: "measured", x: pixel.wavelength_nm.filter((_, i) => pixel.measured[i] !== null),
      y: pixel.measured.filter((v) => v !== null) }];
    if (pixel.fit) series.push({ name: "fitted", kind: "fitted", x: pixel.fit.wavelength_nm, y: pixel.fit.fitted });
    const plot = linePlot({ title: `Pixel (${x}, ${y}): ${pixel.mask.replace("_", " ")}`, xLabel: "wavelength (nm)", yLabel: "reflectance", series });
    plot.id = "pixel-plot";
    pixelBox.replaceChildren(plot);
  };

  let pressed = null;
  canvas.addEventListener("mousemove", (e) => {
    const at = pixelAt(e);
    describePixel(at);
    if (pressed && (at[0] !== pressed[0] || at[1] !== pressed[1])) {
      rect = [Math.min(pressed[0], at[0]), Math.min(pressed[1], at[1]), Math.max(pressed[0], at[0]), Math.max(pressed[1], at[1])];
      showRegion();
    }
  });
  canvas.addEventListener("mousedown", (e) => { pressed = pixelAt(e); });
  canvas.addEventListener("mouseup", (e) => {
    const at = pixelAt(e);
    const dragged = pressed && (at[0] !== pressed[0] || at[1] !== pressed[1]);
    pressed = null;
    if (!dragged) showPixel(at).catch((err) => pixelBox.replaceChildren(h("p", { class: "error", role: "alert" }, err.message)));
  });
  chooser.addEventListener("change", () => { parameter = chooser.value; show(); });

  const counts = Object.entries(map.summary.pixels).map(([reason, n]) => `${reason.replace("_", " ")} ${n}`).join(" · ");
  root.replaceChildren(
    h("section", { class: "card" },
      h("h2", {}, `Map #${map.id}: ${map.name}`),
      h("p", { class: "meta" }, `${cube.samples} × ${cube.lines} pixels · model ${map.summary.model}, ${map.summary.site} · `,
        map.session_id ? h("a", { href: `#/sessions/${map.session_id}` }, `session #${map.session_id}`) : "no session",
        ` · ${when(map.created_at)}`),
      h("p", { class: "meta", id: "map-counts" }, counts),
      h("div", { class: "row" }, h("label", { class: "field" }, h("span", {}, "Parameter"), chooser),
        h("a", { class: "button", href: map.links.header, download: `${map.name}.map.hdr` }, "ENVI header"))),
    h("section", { class: "card" }, h("div", { class: "columns" },
      h("div", { class: "map-frame" }, canvas, selection), barBox), hover, region),
    h("section", { class: "card" }, pixelBox));
  show();
}
