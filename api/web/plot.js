// Line plots as SVG. Each series keeps the exact values it draws in data-x and data-y, so
// that what is on screen can be checked against the API.

const SVG = "http://www.w3.org/2000/svg";

function el(name, attributes = {}, parent = null) {
  const node = document.createElementNS(SVG, name);
  for (const [key, value] of Object.entries(attributes)) node.setAttribute(key, value);
  if (parent) parent.appendChild(node);
  return node;
}

// Round, readable tick values covering [lo, hi].
function ticks(lo, hi, count) {
  const span = hi - lo || Math.abs(hi) || 1;
  const raw = span / count;
  const magnitude = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((m) => m * magnitude).find((s) => s >= raw);
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) out.push(Number(v.toPrecision(12)));
  return out;
}

function format(v) {
  if (v === 0) return "0";
  const a = Math.abs(v);
  return a >= 1e4 || a < 1e-2 ? v.toExponential(1) : String(Number(v.toPrecision(4)));
}

// series: [{name, x: [...], y: [...], kind: "measured"|"fitted"|"residual"|"radiance"}]
export function linePlot({ title, series, xLabel, yLabel, zeroLine = false, width = 640, height = 300 }) {
  const margin = { left: 72, right: 16, top: 28, bottom: 44 };
  const w = width - margin.left - margin.right;
  const h = height - margin.top - margin.bottom;
  const xs = series.flatMap((s) => s.x);
  const ys = series.flatMap((s) => s.y).filter(Number.isFinite);
  const x0 = Math.min(...xs), x1 = Math.max(...xs);
  let y0 = Math.min(...ys), y1 = Math.max(...ys);
  if (zeroLine) { y0 = Math.min(y0, 0); y1 = Math.max(y1, 0); }
  if (y0 === y1) { y0 -= 1; y1 += 1; }
  const pad = (y1 - y0) * 0.05;
  y0 -= pad; y1 += pad;
  const sx = (x) => margin.left + ((x - x0) / (x1 - x0 || 1)) * w;
  const sy = (y) => margin.top + (1 - (y - y0) / (y1 - y0)) * h;

  const svg = el("svg", { viewBox: `0 0 ${width} ${height}`, class: "plot", role: "img", "aria-label": title });
  el("title", {}, svg).textContent = title;
  const axes = el("g", { class: "axes" }, svg);
  for (const t of ticks(x0, x1, 8)) {
    el("line", { x1: sx(t), x2: sx(t), y1: margin.top, y2: margin.top + h, class: "grid" }, axes);
    el("text", { x: sx(t), y: margin.top + h + 18, class: "tick", "text-anchor": "middle" }, axes).textContent = format(t);
  }
  for (const t of ticks(y0, y1, 5)) {
    el("line", { x1: margin.left, x2: margin.left + w, y1: sy(t), y2: sy(t), class: "grid" }, axes);
    el("text", { x: margin.left - 8, y: sy(t) + 5, class: "tick", "text-anchor": "end" }, axes).textContent = format(t);
  }
  if (zeroLine) el("line", { x1: margin.left, x2: margin.left + w, y1: sy(0), y2: sy(0), class: "zero" }, axes);
  el("text", { x: margin.left + w / 2, y: height - 6, class: "label", "text-anchor": "middle" }, axes).textContent = xLabel;
  el("text", { x: 14, y: margin.top + h / 2, class: "label", "text-anchor": "middle",
               transform: `rotate(-90 14 ${margin.top + h / 2})` }, axes).textContent = yLabel;
  el("text", { x: margin.left, y: 18, class: "plot-title" }, axes).textContent = title;

  series.forEach((s, i) => {
    const d = s.x.map((x, k) => `${k ? "L" : "M"}${sx(x).toFixed(2)},${sy(s.y[k]).toFixed(2)}`).join("");
    el("path", { d, class: `series ${s.kind}`, "data-series": s.name,
                 "data-x": JSON.stringify(s.x), "data-y": JSON.stringify(s.y) }, svg);
    // The legend sits in the top margin, right-aligned, where it can never hide a curve.
    const lx = margin.left + w - 130 * (series.length - i), ly = 18;
    el("line", { x1: lx, x2: lx + 24, y1: ly - 5, y2: ly - 5, class: `series ${s.kind}` }, svg);
    el("text", { x: lx + 30, y: ly, class: "legend" }, svg).textContent = s.name;
  });
  return svg;
}
