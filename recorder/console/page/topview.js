// The top view: a trial from above (x across, z in depth, session units) as the solver
// solved it, and its legend in the words of the method's page (the server's).
"use strict";

// The marks' and the grid's colours. Each segment brings its own style from the server
// (twopose.methods.topview.SegmentKind: colour, width, dash), so a new kind draws as declared.
const COLOURS = {
  centre: "#1f5fbf", estimate: "#d62728", truth: "#2ca02c", grid: "#e3e7ec", axis: "#5b6673",
};

function legendItems(view, page, next) {
  // [class, mark, words, colour]: a mark's colour is its class' (style.css) or its segment's.
  const styles = new Map(view.segments.map((g) => [g.kind, g.style]));
  const items = [["centre", "▲", page.legend_cameras, null]];
  if (next && page.legend_next) items.push(["centre", "△", page.legend_next, null]);
  for (const [kind, mark, words] of page.legend_segments) {
    if (styles.has(kind)) items.push(["segment", mark, words, styles.get(kind).colour]);
  }
  if (view.estimate) items.push(["estimate", "✕", page.estimate_label, null]);
  if (view.truth) items.push(["truth", "○", page.truth_label, null]);
  return items;
}

function niceStep(span) {
  const raw = span / 5;
  const p = Math.pow(10, Math.floor(Math.log10(raw)));
  const m = raw / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

function drawTopView(view, units, page, next) {
  const canvas = $("topview");
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, canvas.clientWidth), h = Math.max(1, canvas.clientHeight);
  canvas.width = Math.round(w * dpr);
  canvas.height = Math.round(h * dpr);
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const legend = $("topview-legend");
  if (!view) {
    setText($("topview-title"), "");
    legend.replaceChildren();
    ctx.fillStyle = COLOURS.axis;
    ctx.font = "13px 'twopose Sans', sans-serif";
    ctx.textAlign = "center";
    ctx.fillText(page.topview_empty[0], w / 2, h / 2 - 9);
    ctx.fillText(page.topview_empty[1], w / 2, h / 2 + 9);
    return;
  }
  setText($("topview-title"), page.topview_title.replace("{trial}", view.trial));
  legend.replaceChildren(...legendItems(view, page, next).map(([cls, mark, text, colour]) => {
    const li = el("li");
    const span = el("span", mark, "mark " + cls);
    if (colour) span.style.color = colour;
    li.append(span, el("span", text));
    return li;
  }));

  const points = [...view.cameras];
  const suggested = next ? [next[0], next[2]] : null; // the top view is x across, z in depth
  if (suggested) points.push(suggested);
  for (const g of view.segments) points.push(g.from, g.to);
  if (view.estimate) points.push(view.estimate);
  if (view.truth) points.push(view.truth);
  const finite = points.filter((p) => p && Number.isFinite(p[0]) && Number.isFinite(p[1]));
  if (!finite.length) return;
  let x0 = Math.min(...finite.map((p) => p[0])), x1 = Math.max(...finite.map((p) => p[0]));
  let z0 = Math.min(...finite.map((p) => p[1])), z1 = Math.max(...finite.map((p) => p[1]));
  const span = Math.max(x1 - x0, z1 - z0, 1e-6);
  x0 -= 0.06 * span; x1 += 0.06 * span; z0 -= 0.06 * span; z1 += 0.06 * span;
  const left = 46, right = w - 10, top = 10, bottom = h - 30;
  const pw = Math.max(10, right - left), ph = Math.max(10, bottom - top);
  const scale = Math.min(pw / Math.max(x1 - x0, 1e-9), ph / Math.max(z1 - z0, 1e-9));
  const xc = (x0 + x1) / 2, zc = (z0 + z1) / 2;
  const X = (x) => left + pw / 2 + (x - xc) * scale;
  const Y = (z) => top + ph / 2 - (z - zc) * scale; // z grows upwards: away from the rig
  const visX = [xc - pw / 2 / scale, xc + pw / 2 / scale];
  const visZ = [zc - ph / 2 / scale, zc + ph / 2 / scale];

  // Grid and axes, labelled in the session's units.
  const step = niceStep(Math.max(visX[1] - visX[0], visZ[1] - visZ[0]));
  const label = (v) => String(Number(v.toFixed(6)));
  ctx.lineWidth = 1;
  ctx.font = "12px 'twopose Sans', sans-serif";
  ctx.fillStyle = COLOURS.axis;
  ctx.textAlign = "center";
  ctx.textBaseline = "top";
  for (let x = Math.ceil(visX[0] / step) * step; x <= visX[1]; x += step) {
    ctx.strokeStyle = Math.abs(x) < step / 1e6 ? "#b9c2cc" : COLOURS.grid;
    ctx.beginPath(); ctx.moveTo(X(x), top); ctx.lineTo(X(x), bottom); ctx.stroke();
    ctx.fillText(label(x), X(x), bottom + 3);
  }
  ctx.textAlign = "right";
  ctx.textBaseline = "middle";
  for (let z = Math.ceil(visZ[0] / step) * step; z <= visZ[1]; z += step) {
    ctx.strokeStyle = Math.abs(z) < step / 1e6 ? "#b9c2cc" : COLOURS.grid;
    ctx.beginPath(); ctx.moveTo(left, Y(z)); ctx.lineTo(right, Y(z)); ctx.stroke();
    ctx.fillText(label(z), left - 4, Y(z));
  }
  ctx.strokeStyle = COLOURS.axis;
  ctx.strokeRect(left, top, pw, ph);
  ctx.textAlign = "right";
  ctx.textBaseline = "bottom";
  ctx.fillText("x (" + units + ") →", right, h - 1);
  ctx.save();
  ctx.translate(12, top + ph / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  ctx.fillText("z (" + units + ") →", 0, 0);
  ctx.restore();

  // What each view measured, then the cameras, the truth and the estimate on top.
  ctx.save();
  ctx.beginPath();
  ctx.rect(left, top, pw, ph);
  ctx.clip();
  for (const g of view.segments) {
    const style = g.style || {};
    ctx.strokeStyle = style.colour || COLOURS.axis;
    ctx.lineWidth = style.width || 2;
    ctx.setLineDash(style.dash || []);
    ctx.beginPath();
    ctx.moveTo(X(g.from[0]), Y(g.from[1]));
    ctx.lineTo(X(g.to[0]), Y(g.to[1]));
    ctx.stroke();
  }
  ctx.setLineDash([]);
  ctx.fillStyle = COLOURS.centre;
  for (const c of view.cameras) {
    const cx = X(c[0]), cy = Y(c[1]);
    ctx.beginPath(); ctx.moveTo(cx, cy - 8); ctx.lineTo(cx - 7, cy + 5); ctx.lineTo(cx + 7, cy + 5); ctx.closePath(); ctx.fill();
  }
  if (suggested) { // the suggested next pose: a hollow camera, dashed
    const cx = X(suggested[0]), cy = Y(suggested[1]);
    ctx.strokeStyle = COLOURS.centre; ctx.lineWidth = 2; ctx.setLineDash([3, 2]);
    ctx.beginPath(); ctx.moveTo(cx, cy - 8); ctx.lineTo(cx - 7, cy + 5); ctx.lineTo(cx + 7, cy + 5); ctx.closePath(); ctx.stroke();
    ctx.setLineDash([]);
  }
  if (view.truth) {
    ctx.strokeStyle = COLOURS.truth; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.arc(X(view.truth[0]), Y(view.truth[1]), 7, 0, 2 * Math.PI); ctx.stroke();
  }
  if (view.estimate) {
    const ex = X(view.estimate[0]), ey = Y(view.estimate[1]);
    ctx.strokeStyle = COLOURS.estimate; ctx.lineWidth = 2.5;
    ctx.beginPath(); ctx.moveTo(ex - 6, ey - 6); ctx.lineTo(ex + 6, ey + 6); ctx.moveTo(ex + 6, ey - 6); ctx.lineTo(ex - 6, ey + 6); ctx.stroke();
  }
  ctx.restore();
}

// ---------------------------------------------------------------------------- the map
// Under the top view: what one more pose from each cell of the grid paper would give
// (twopose.guidance.region_map.RegionMap.to_json): the trial's predicted 95% region, or with one
// pose the worst regret over the depths weighed. The map covers the cells worth seeing;
// its best is the suggestion. Darker green is better; a cell that would put the target
// near the image's edge is blank, one taken, over clutter or that would not solve is
// hatched: none of them ever looks good. Every text drawn on the canvas is kept with its
// box (the canvas' data-labels), so that none is drawn over another.
const MAP_SCALE = ["#006837", "#31a354", "#78c679", "#c2e699", "#ffffcc"]; // best .. worst
const MAP_FONT = 11; // px: the ticks and the numbers

function mapColour(value, scale) {
  const [lo, hi] = scale;
  const t = hi > lo ? Math.min(1, Math.max(0, (value - lo) / (hi - lo))) : 0;
  const at = t * (MAP_SCALE.length - 1);
  const k = Math.min(MAP_SCALE.length - 2, Math.floor(at));
  const mix = (a, b, f) => Math.round(a + (b - a) * f);
  const rgb = (hex) => [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16));
  const [a, b] = [rgb(MAP_SCALE[k]), rgb(MAP_SCALE[k + 1])];
  return "rgb(" + a.map((v, i) => mix(v, b[i], at - k)).join(",") + ")";
}

function hatch(ctx, colour) {
  const tile = document.createElement("canvas");
  tile.width = tile.height = 8;
  const t = tile.getContext("2d");
  t.fillStyle = "#ffffff"; t.fillRect(0, 0, 8, 8);
  t.strokeStyle = colour; t.lineWidth = 1.5;
  t.beginPath(); t.moveTo(0, 8); t.lineTo(8, 0); t.moveTo(-2, 2); t.lineTo(2, -2); t.moveTo(6, 10); t.lineTo(10, 6); t.stroke();
  return ctx.createPattern(tile, "repeat");
}

function triangle(ctx, cx, cy, r) {
  ctx.beginPath(); ctx.moveTo(cx, cy - r); ctx.lineTo(cx - 0.875 * r, cy + 0.625 * r); ctx.lineTo(cx + 0.875 * r, cy + 0.625 * r); ctx.closePath();
}

const tickLabel = (v) => String(Number(v.toFixed(6)));

function niceAbove(least) {
  // The least of 1, 2, 5 times a power of ten at or above ``least``.
  const p = Math.pow(10, Math.floor(Math.log10(least)));
  for (const m of [1, 2, 5, 10]) if (m * p >= least * (1 - 1e-9)) return m * p;
  return 10 * p;
}

function tickStep(lo, hi, pixelsPerUnit, room) {
  // The least nice step whose ticks stand at least ``room(step)`` pixels apart.
  let step = niceAbove(Math.max((hi - lo) / 12, 1e-9));
  for (let k = 0; k < 40 && step * pixelsPerUnit < room(step); k++) step = niceAbove(step * 1.01);
  return step;
}

function mapFrame(ctx, map, next, w, h) {
  // The cells' extent (and the poses', the suggestion's) mapped onto the canvas, x across
  // and z upwards as in the top view, one scale for both, room left for the ticks.
  const half = map.cell / 2;
  let xs = [map.x[0], map.x[map.x.length - 1], ...map.taken.map((p) => p[0])];
  let zs = [map.z[0], map.z[map.z.length - 1], ...map.taken.map((p) => p[1])];
  if (next) { xs.push(next[0]); zs.push(next[2]); }
  xs = xs.filter(Number.isFinite); zs = zs.filter(Number.isFinite); // no cells: the poses'
  const x0 = Math.min(...xs) - half, x1 = Math.max(...xs) + half;
  const z0 = Math.min(...zs) - half, z1 = Math.max(...zs) + half;
  ctx.font = MAP_FONT + "px 'twopose Sans', sans-serif";
  // The widest z label there can be: the largest magnitude, negative, at a fine step.
  const fine = niceAbove(Math.max((z1 - z0) / 12, 1e-9));
  const most = Math.ceil(Math.max(Math.abs(z0), Math.abs(z1)) / fine) * fine;
  const widest = ctx.measureText(tickLabel(-most)).width;
  const left = Math.ceil(widest) + 10, top = 12, bottom = MAP_FONT + 8, right = 12;
  const room = [Math.max(10, w - left - right), Math.max(10, h - top - bottom)];
  const scale = Math.min(room[0] / Math.max(x1 - x0, 1e-9), room[1] / Math.max(z1 - z0, 1e-9));
  const pw = (x1 - x0) * scale, ph = (z1 - z0) * scale;
  const l = left + (room[0] - pw) / 2, t = top + (room[1] - ph) / 2;
  return {
    left: l, top: t, pw, ph, scale,
    X: (x) => l + (x - x0) * scale,
    Y: (z) => t + ph - (z - z0) * scale,
    x0, x1, z0, z1,
  };
}

function overlaps(a, b) {
  return a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
}

function drawMapAxes(ctx, f, labels) {
  // Ticks on both axes, each step wide enough for its labels (no "-1000-500").
  ctx.font = MAP_FONT + "px 'twopose Sans', sans-serif";
  ctx.fillStyle = COLOURS.axis;
  const wide = (step) => {
    let most = 0;
    for (let x = Math.ceil(f.x0 / step) * step; x <= f.x1 + 1e-9 * step; x += step) most = Math.max(most, ctx.measureText(tickLabel(x)).width);
    return most + 8;
  };
  const sx = tickStep(f.x0, f.x1, f.scale, wide);
  const sz = tickStep(f.z0, f.z1, f.scale, () => MAP_FONT + 4);
  ctx.textAlign = "center"; ctx.textBaseline = "top";
  for (let x = Math.ceil(f.x0 / sx) * sx; x <= f.x1 + 1e-9 * sx; x += sx) {
    const text = tickLabel(x), width = ctx.measureText(text).width, cx = f.X(x), cy = f.top + f.ph + 3;
    ctx.fillText(text, cx, cy);
    labels.push({kind: "tick", text, x0: cx - width / 2, x1: cx + width / 2, y0: cy, y1: cy + MAP_FONT});
  }
  ctx.textAlign = "right"; ctx.textBaseline = "middle";
  for (let z = Math.ceil(f.z0 / sz) * sz; z <= f.z1 + 1e-9 * sz; z += sz) {
    const text = tickLabel(z), width = ctx.measureText(text).width, cx = f.left - 4, cy = f.Y(z);
    ctx.fillText(text, cx, cy);
    labels.push({kind: "tick", text, x0: cx - width, x1: cx, y0: cy - MAP_FONT / 2, y1: cy + MAP_FONT / 2});
  }
  ctx.strokeStyle = COLOURS.axis;
  ctx.lineWidth = 1;
  ctx.strokeRect(f.left, f.top, f.pw, f.ph);
}

function drawMapCells(ctx, map, f) {
  const size = map.cell * f.scale;
  const hatched = hatch(ctx, "#8d96a0");
  for (let j = 0; j < map.z.length; j++) {
    for (let i = 0; i < map.x.length; i++) {
      const reason = map.reason[j][i], value = map.values[j][i];
      const x = f.X(map.x[i]) - size / 2, y = f.Y(map.z[j]) - size / 2;
      if (reason === 0 && value !== null) ctx.fillStyle = mapColour(value, map.scale);
      else if (reason === 1) continue; // near the image's edge: blank
      else ctx.fillStyle = hatched; // taken, over clutter, or would not solve
      ctx.fillRect(x, y, size + 0.5, size + 0.5);
    }
  }
}

function drawMapMarks(ctx, map, f, next, labels) {
  // The marks fit the cells: a numbered mark is drawn only where it overlaps none drawn.
  const r = Math.max(6, Math.min(9, 0.45 * map.cell * f.scale));
  const taken = r * 0.9;
  ctx.lineWidth = 1.5;
  for (const [x, z] of map.taken) { // the poses taken: the top view's cameras
    triangle(ctx, f.X(x), f.Y(z), taken);
    ctx.fillStyle = COLOURS.centre; ctx.fill(); ctx.strokeStyle = "#ffffff"; ctx.stroke();
  }
  const marks = [];
  if (map.best) { // the best: a ring (the suggestion, which the search refined from the cells)
    const cx = f.X(map.best.t_grid[0]), cy = f.Y(map.best.t_grid[2]), R = r + 4;
    ctx.strokeStyle = "#ffffff"; ctx.lineWidth = 5;
    ctx.beginPath(); ctx.arc(cx, cy, R, 0, 2 * Math.PI); ctx.stroke();
    ctx.strokeStyle = "#c0392b"; ctx.lineWidth = 2.5;
    ctx.beginPath(); ctx.arc(cx, cy, R, 0, 2 * Math.PI); ctx.stroke();
    marks.push({kind: "ring", text: "1", x0: cx - R - 2, x1: cx + R + 2, y0: cy - R - 2, y1: cy + R + 2});
  }
  map.top.slice(1).forEach((p, k) => { // the next best, numbered
    const cx = f.X(p.t_grid[0]), cy = f.Y(p.t_grid[2]);
    const box = {kind: "number", text: String(k + 2), x0: cx - r - 1, x1: cx + r + 1, y0: cy - r - 1, y1: cy + r + 1};
    if (marks.some((m) => overlaps(m, box))) return; // listed under the map all the same
    ctx.fillStyle = "#ffffff"; ctx.strokeStyle = "#1d232b"; ctx.lineWidth = 1.5;
    ctx.beginPath(); ctx.arc(cx, cy, r, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    ctx.fillStyle = "#1d232b"; ctx.font = "bold " + Math.round(r * 1.3) + "px 'twopose Sans', sans-serif";
    ctx.textAlign = "center"; ctx.textBaseline = "middle";
    ctx.fillText(box.text, cx, cy + 0.5);
    marks.push(box);
  });
  if (next) { // the suggestion: the top view's hollow camera, dashed
    triangle(ctx, f.X(next[0]), f.Y(next[2]), r);
    ctx.fillStyle = "#ffffff"; ctx.fill();
    ctx.strokeStyle = COLOURS.centre; ctx.lineWidth = 2; ctx.setLineDash([3, 2]); ctx.stroke();
    ctx.setLineDash([]);
  }
  labels.push(...marks);
}

function drawMapScale(map) {
  // The colour scale: its ends as the server words them, the worse end "or more".
  const canvas = $("regionmap-scale");
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, canvas.clientWidth), h = Math.max(1, canvas.clientHeight);
  canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  const gradient = ctx.createLinearGradient(0, 0, w, 0);
  MAP_SCALE.forEach((c, k) => gradient.addColorStop(k / (MAP_SCALE.length - 1), c));
  ctx.fillStyle = gradient;
  ctx.fillRect(0, 0, w, h);
  setText($("regionmap-lo"), map.scale_text[0]);
  setText($("regionmap-hi"), map.scale_text[1]);
}

function drawRegionMap(map, next) {
  show($("regionmap-section"), !!map);
  if (!map) return;
  setText($("regionmap-title"), map.label);
  drawMapScale(map);
  $("regionmap-best").replaceChildren(...map.top.map((p, k) => {
    const [x, y, z] = p.t_grid;
    const where = "x " + num(x) + ", y " + num(y) + ", z " + num(z) + " " + map.units;
    const li = el("li", where + ": " + p.text + (k === 0 ? " (ringed)" : ""));
    li.dataset.testid = "region-map-pose";
    return li;
  }));
  setText($("regionmap-note"), map.note);
  const canvas = $("regionmap");
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, canvas.clientWidth), h = Math.max(1, canvas.clientHeight);
  canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const f = mapFrame(ctx, map, next, w, h);
  const labels = [];
  ctx.save();
  ctx.beginPath(); ctx.rect(f.left, f.top, f.pw, f.ph); ctx.clip();
  if (map.x.length && map.z.length) drawMapCells(ctx, map, f);
  ctx.restore();
  drawMapMarks(ctx, map, f, next, labels); // unclipped: a mark on the map's edge shows whole
  drawMapAxes(ctx, f, labels);
  canvas.dataset.labels = JSON.stringify(labels);
}
