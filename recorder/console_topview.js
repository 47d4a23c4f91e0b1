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
    ctx.font = "13px sans-serif";
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
  ctx.font = "12px sans-serif";
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
