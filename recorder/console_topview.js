// The top view: a trial from above (x across, z in depth, session units) as the solver
// solved it, and its legend in the words of the method's page (the server's).
"use strict";

// Each segment kind's colour (twopose.topview.TopView), and the marks' and grid's.
const COLOURS = {
  corners: "#333f4d",
  centre: "#1f5fbf", ray: "#e07b00", trace: "#8e44ad", estimated_line: "#d62728",
  truth_line: "#2ca02c", estimate: "#d62728", truth: "#2ca02c", grid: "#e3e7ec", axis: "#5b6673",
};
const WIDTHS = {corners: 3, estimated_line: 3}; // the others' 2
const DASHES = {truth_line: [7, 5]}; // the others' solid

function legendItems(view, page, next) {
  // [kind, mark, words]: the kind is the mark's colour (console.css).
  const kinds = new Set(view.segments.map((g) => g.kind));
  const items = [["centre", "▲", page.legend_cameras]];
  if (next && page.legend_next) items.push(["centre", "△", page.legend_next]);
  for (const [kind, mark, words] of page.legend_segments) {
    if (kinds.has(kind)) items.push([kind, mark, words]);
  }
  if (view.estimate) items.push(["estimate", "✕", page.estimate_label]);
  if (view.truth) items.push(["truth", "○", page.truth_label]);
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
  legend.replaceChildren(...legendItems(view, page, next).map(([kind, mark, text]) => {
    const li = el("li");
    li.append(el("span", mark, "mark " + kind), el("span", text));
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
    ctx.strokeStyle = COLOURS[g.kind] || COLOURS.axis;
    ctx.lineWidth = WIDTHS[g.kind] || 2;
    ctx.setLineDash(DASHES[g.kind] || []);
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
// Under the top view: the trial's predicted 95% region with one more pose from each cell
// of the grid paper in reach (twopose.region_map.RegionMap.to_json), so an operator who
// cannot reach the suggestion sees the good poses near it. Darker green is better; a cell
// that would put the target near the image's edge is blank, one taken or that would not
// solve is hatched: none of them ever looks good.
const MAP_SCALE = ["#006837", "#31a354", "#78c679", "#c2e699", "#ffffcc"]; // best .. worst

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

function triangle(ctx, cx, cy) {
  ctx.beginPath(); ctx.moveTo(cx, cy - 8); ctx.lineTo(cx - 7, cy + 5); ctx.lineTo(cx + 7, cy + 5); ctx.closePath();
}

function mapFrame(map, next, w, h) {
  // The cells' extent (and the poses', the suggestion's) mapped onto the canvas, x across
  // and z upwards as in the top view, one scale for both.
  const half = map.cell / 2;
  const xs = [map.x[0] - half, map.x[map.x.length - 1] + half, ...map.taken.map((p) => p[0])];
  const zs = [map.z[0] - half, map.z[map.z.length - 1] + half, ...map.taken.map((p) => p[1])];
  if (next) { xs.push(next[0]); zs.push(next[2]); }
  const x0 = Math.min(...xs), x1 = Math.max(...xs), z0 = Math.min(...zs), z1 = Math.max(...zs);
  const room = [Math.max(10, w - 54), Math.max(10, h - 40)];
  const scale = Math.min(room[0] / Math.max(x1 - x0, 1e-9), room[1] / Math.max(z1 - z0, 1e-9)) * 0.96;
  // The frame fits the map (no empty paper either side), centred in the canvas.
  const pw = Math.min(room[0], (x1 - x0) * scale / 0.96), ph = Math.min(room[1], (z1 - z0) * scale / 0.96);
  const left = 46 + (room[0] - pw) / 2, top = 10;
  const xc = (x0 + x1) / 2, zc = (z0 + z1) / 2;
  return {
    left, top, pw, ph, scale,
    X: (x) => left + pw / 2 + (x - xc) * scale,
    Y: (z) => top + ph / 2 - (z - zc) * scale,
    visX: [xc - pw / 2 / scale, xc + pw / 2 / scale],
    visZ: [zc - ph / 2 / scale, zc + ph / 2 / scale],
  };
}

function drawMapAxes(ctx, f, units, w, h) {
  const step = niceStep(Math.max(f.visX[1] - f.visX[0], f.visZ[1] - f.visZ[0]));
  const label = (v) => String(Number(v.toFixed(6)));
  ctx.font = "12px 'twopose Sans', sans-serif";
  ctx.fillStyle = COLOURS.axis;
  ctx.textAlign = "center"; ctx.textBaseline = "top";
  for (let x = Math.ceil(f.visX[0] / step) * step; x <= f.visX[1]; x += step) ctx.fillText(label(x), f.X(x), f.top + f.ph + 3);
  ctx.textAlign = "right"; ctx.textBaseline = "middle";
  for (let z = Math.ceil(f.visZ[0] / step) * step; z <= f.visZ[1]; z += step) ctx.fillText(label(z), f.left - 4, f.Y(z));
  ctx.strokeStyle = COLOURS.axis;
  ctx.strokeRect(f.left, f.top, f.pw, f.ph);
  ctx.textAlign = "right"; ctx.textBaseline = "bottom";
  ctx.fillText("x (" + units + ") →", f.left + f.pw, f.top + f.ph + 29);
  ctx.save();
  ctx.translate(f.left - 34, f.top + f.ph / 2); ctx.rotate(-Math.PI / 2);
  ctx.textAlign = "center"; ctx.textBaseline = "middle";
  ctx.fillText("z (" + units + ") →", 0, 0);
  ctx.restore();
}

function drawMapCells(ctx, map, f) {
  const size = map.cell * f.scale;
  const hatched = hatch(ctx, "#8d96a0");
  for (let j = 0; j < map.z.length; j++) {
    for (let i = 0; i < map.x.length; i++) {
      const reason = map.reason[j][i], value = map.region95[j][i];
      const x = f.X(map.x[i]) - size / 2, y = f.Y(map.z[j]) - size / 2;
      if (reason === 0 && value !== null) ctx.fillStyle = mapColour(value, map.scale);
      else if (reason === 1) continue; // near the image's edge: blank
      else ctx.fillStyle = hatched; // taken, or would not solve
      ctx.fillRect(x, y, size + 0.5, size + 0.5);
    }
  }
}

function drawMapMarks(ctx, map, f, next) {
  ctx.lineWidth = 1.5;
  for (const [x, z] of map.taken) { // the poses taken: the top view's cameras
    triangle(ctx, f.X(x), f.Y(z));
    ctx.fillStyle = COLOURS.centre; ctx.fill(); ctx.strokeStyle = "#ffffff"; ctx.stroke();
  }
  map.top.slice(1).forEach((p, k) => { // the next best, numbered
    const cx = f.X(p.t_grid[0]), cy = f.Y(p.t_grid[2]);
    ctx.fillStyle = "#ffffff"; ctx.strokeStyle = "#1d232b";
    ctx.beginPath(); ctx.arc(cx, cy, 7, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    ctx.fillStyle = "#1d232b"; ctx.font = "bold 10px 'twopose Sans', sans-serif";
    ctx.textAlign = "center"; ctx.textBaseline = "middle";
    ctx.fillText(String(k + 2), cx, cy + 0.5);
  });
  if (map.best) { // the best: a ring
    const cx = f.X(map.best.t_grid[0]), cy = f.Y(map.best.t_grid[2]);
    ctx.strokeStyle = "#ffffff"; ctx.lineWidth = 5;
    ctx.beginPath(); ctx.arc(cx, cy, 11, 0, 2 * Math.PI); ctx.stroke();
    ctx.strokeStyle = "#c0392b"; ctx.lineWidth = 2.5;
    ctx.beginPath(); ctx.arc(cx, cy, 11, 0, 2 * Math.PI); ctx.stroke();
  }
  if (next) { // the suggestion: the top view's hollow camera, dashed
    triangle(ctx, f.X(next[0]), f.Y(next[2]));
    ctx.fillStyle = "#ffffff"; ctx.fill();
    ctx.strokeStyle = COLOURS.centre; ctx.lineWidth = 2; ctx.setLineDash([3, 2]); ctx.stroke();
    ctx.setLineDash([]);
  }
}

function drawMapScale(map) {
  // The colour scale: its ends in the session's units, the worse end "or more".
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
  const [lo, hi] = map.scale;
  setText($("regionmap-lo"), num(lo) + " " + map.units + " (best)");
  setText($("regionmap-hi"), num(hi) + " " + map.units + " or more");
}

function mapPoseText(p, units) {
  const [x, y, z] = p.t_grid;
  return "x " + num(x) + ", y " + num(y) + ", z " + num(z) + " " + units + ": within " + num(p.region95) + " " + units;
}

function drawRegionMap(map, next) {
  show($("regionmap-section"), !!map);
  if (!map) return;
  const canvas = $("regionmap");
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, canvas.clientWidth), h = Math.max(1, canvas.clientHeight);
  canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
  const ctx = canvas.getContext("2d");
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  const f = mapFrame(map, next, w, h);
  ctx.save();
  ctx.beginPath(); ctx.rect(f.left, f.top, f.pw, f.ph); ctx.clip();
  if (map.x.length && map.z.length) drawMapCells(ctx, map, f);
  ctx.restore();
  drawMapMarks(ctx, map, f, next); // unclipped: a mark on the map's edge shows whole
  drawMapAxes(ctx, f, map.units, w, h);
  setText($("regionmap-units"), "predicted 95% region, " + map.units);
  drawMapScale(map);
  const every = map.step > 1 ? "a cell every " + map.step + " lines of the paper; " : "a cell a pose; ";
  const assumed = map.assumed_depth === null ? "" : "; one pose: the target assumed " +
    num(map.assumed_depth) + " " + map.units + " along its ray (the suggestion is chosen for every depth the scene allows)";
  setText($("regionmap-title"), "the trial's region with the next pose there: " + every + map.n_predicted +
    " predicted of the " + map.n_in_view + " poses in view" + assumed);
  $("regionmap-best").replaceChildren(...map.top.map((p, k) => {
    const li = el("li", mapPoseText(p, map.units) + (k === 0 ? " (ringed)" : ""));
    li.dataset.testid = "region-map-pose";
    return li;
  }));
}
