// The live pointing panel (issue 58 item 5): where the finger points on the floor, pushed by
// the recorder pair by pair (GET /api/pointing, Server-Sent Events; never polled): the point,
// its 95% region, the last second's track and the pair's conditioning in words (a
// near-singular pair is said as such and drawn without a point). The page's clock is set
// against the recorder's (GET /api/clock, the round trip with the shortest time), so the
// panel says how long each pair took from its capture to the page; every pair's times are
// kept in window.twoposePointing for whoever measures them (benchmarks/bench_pointing.py).
// Loaded after util.js; does nothing on a page without the panel.
"use strict";

const POINTING = {
  status: {running: false, words: "connecting to the recorder..."},
  last: null, // the newest pair
  lastOk: null, // the newest pair with a point
  final: null, // the last pair before the pair stopped (drawn greyed)
  arrived: [], // pairs arrived since the last drawing: [seq, arrival ms]
  scheduled: false,
  rate: [], // arrival times of the last second's pairs (ms)
  span: null, // the drawing's half-width, session units (grows, shrinks slowly)
};
// What a benchmark reads: the clock's offset (server ms minus page ms) and its round trip,
// and per pair [seq, capture ms, sent ms (server), arrived ms (page), drawn ms (page)].
window.twoposePointing = {clock: {offset_ms: null, rtt_ms: null}, log: [], missed: 0};
const LOG_LIMIT = 200000;
const CLOCK_EVERY_MS = 2000;

async function syncClock(trips) {
  // Round trips to the recorder's clock; the shortest one's midpoint (of all so far: both
  // clocks are the machine's monotonic clock, so the offset holds) is the best estimate.
  const clock = window.twoposePointing.clock;
  for (let k = 0; k < trips; k++) {
    const before = performance.now();
    let answer;
    try {
      answer = await (await fetch("/api/clock", {cache: "no-store"})).json();
    } catch (err) {
      return;
    }
    const after = performance.now();
    const rtt = after - before;
    if (clock.rtt_ms === null || rtt <= clock.rtt_ms) {
      clock.rtt_ms = rtt;
      clock.offset_ms = answer.t_ns / 1e6 - (before + after) / 2;
    }
  }
}

function pointingMessage(event) {
  const arrived = performance.now();
  let m;
  try {
    m = JSON.parse(event.data);
  } catch (err) {
    return;
  }
  if (m.kind === "status") {
    POINTING.status = m;
    if (!m.running && POINTING.last) POINTING.final = POINTING.last; // kept, greyed
    if (!m.running) POINTING.last = null;
    if (m.running) POINTING.final = null;
  } else if (m.kind === "missed") {
    window.twoposePointing.missed += m.count;
  } else if (m.kind === "estimate") {
    POINTING.last = m;
    if (m.point) POINTING.lastOk = m;
    POINTING.arrived.push([m.seq, arrived]);
    POINTING.rate.push(arrived);
    const log = window.twoposePointing.log;
    if (log.length < LOG_LIMIT) log.push([m.seq, m.t_capture_ns / 1e6, m.sent_ns / 1e6, arrived, null]);
  }
  if (!POINTING.scheduled) {
    POINTING.scheduled = true;
    requestAnimationFrame(drawPointing);
  }
}

function drawPointing() {
  POINTING.scheduled = false;
  renderPointing();
  const drawnAt = performance.now();
  const log = window.twoposePointing.log;
  // Every pair that arrived since the last drawing is on the screen from this frame on.
  for (let k = log.length - 1, n = POINTING.arrived.length; k >= 0 && n > 0; k--) {
    if (log[k][4] === null) {
      log[k][4] = drawnAt;
      n--;
    }
  }
  POINTING.arrived = [];
}

function latencyMs(pair, pageMs) {
  const clock = window.twoposePointing.clock;
  if (clock.offset_ms === null) return null;
  return pageMs + clock.offset_ms - pair.t_capture_ns / 1e6;
}

function renderPointing() {
  const s = POINTING.status;
  const pair = POINTING.last;
  const running = Boolean(s.running);
  // Stopped: the last pair's drawing stays, greyed, under why it stopped.
  const final = running ? null : POINTING.final || null;
  // a pair's recording shows the panel from the start: its words say no trial streams yet
  // (the third column stood empty before: a new user's r7 K5)
  const pairPage = document.body.classList.contains("two-cameras");
  const shown = running || final !== null || pairPage;
  const badge = $("pointing-badge");
  if (badge) {
    show($("pointing"), shown);
    show(badge, !shown);
    setText(badge, shown ? "" : "pointing: " + (s.words || "no pair running"));
  }
  $("pointing").classList.toggle("pointing-live", shown);
  show($("pointing-box"), running || final !== null);
  $("pointing-box").classList.toggle("stopped", final !== null);
  setText($("pointing-aside"), running ? s.about || "" : "");
  const words = $("pointing-conditioning");
  words.className = "pointing-words";
  if (!running) {
    setText(words, s.words || "no pair running");
    words.classList.add("idle");
    setText($("pointing-where"), "");
    setText($("pointing-timing"), "");
    if (final) drawFloor($("pointing-canvas"), final, s);
    return;
  }
  if (!pair) {
    setText(words, "waiting for the first pair...");
    words.classList.add("idle");
  } else if ((s.warnings || []).length || pair.warning) {
    // A warning that voids every point (one recording given twice, or the pairs' frames
    // alike): never "ok" over it.
    const warnings = [...(s.warnings || []), ...(pair.warning ? [pair.warning] : [])];
    setText(words, "not to be trusted: " + warnings.join("; "));
    words.classList.add("singular");
  } else if (pair.point) {
    setText(words, "conditioning: ok");
    words.classList.add("ok");
  } else {
    setText(words, "no point: " + pair.words);
    words.classList.add(pair.status === "near_singular" ? "singular" : "lost");
  }
  drawFloor($("pointing-canvas"), pair, s);
  const [where, timing] = pointingNumbers(pair, s);
  setText($("pointing-where"), where);
  // Where each camera's pixel noise (the region's) came from, on hovering the numbers.
  $("pointing-where").title = ((pair && pair.noise) || []).filter(Boolean)
    .map((w, i) => `camera ${i + 1}: ${w}`).join("\n");
  setText($("pointing-timing"), timing);
}

function pointingNumbers(pair, s) {
  // Two lines: where the point is (and its region), then how fast the pairs come.
  if (!pair) return ["", ""];
  const now = performance.now();
  while (POINTING.rate.length && POINTING.rate[0] < now - 1000) POINTING.rate.shift();
  let where = "no point";
  if (pair.point) {
    where = `${s.axes[0]} ${fixed(pair.point[0], 2)}, ${s.axes[1]} ${fixed(pair.point[1], 2)} ${s.units}`;
    if (pair.region) where += ` · 95%: ±${fixed(pair.region.major, 2)} × ${fixed(pair.region.minor, 2)} ${s.units}`;
  }
  const timing = [];
  const late = latencyMs(pair, now);
  const rtt = window.twoposePointing.clock.rtt_ms;
  if (late !== null) {
    // A negative latency is the clocks' mapping (±half a round trip), never a pair early.
    const half = fixed(rtt / 2, 0);
    timing.push(late >= 0 ? `capture to page ${fixed(late, 0)} ms (±${half})`
      : `capture to page within the clocks' ±${half} ms`);
  }
  timing.push(`${POINTING.rate.length} pairs/s`);
  timing.push(`pair ${pair.seq + 1}`);
  return [where, timing.join(" · ")];
}

function drawFloor(canvas, pair, s) {
  // The canvas takes its box's size (style.css); its pixels follow it.
  const ratio = window.devicePixelRatio || 1;
  const w = Math.max(1, canvas.clientWidth);
  const h = Math.max(1, canvas.clientHeight);
  if (canvas.width !== Math.round(w * ratio) || canvas.height !== Math.round(h * ratio)) {
    canvas.width = Math.round(w * ratio);
    canvas.height = Math.round(h * ratio);
  }
  const g = canvas.getContext("2d");
  g.setTransform(ratio, 0, 0, ratio, 0, 0);
  g.clearRect(0, 0, w, h);
  const shown = pair && pair.point ? pair : POINTING.lastOk;
  const track = pair ? pair.track : [];
  // The view: centred on the track, wide enough for it and the region, never narrower
  // than the status' span (a few inches in the session's units).
  const pts = track.map((p) => [p[1], p[2]]);
  if (shown && shown.point) pts.push(shown.point);
  let cx = 0;
  let cy = 0;
  let need = s.span || 1;
  if (pts.length) {
    const xs = pts.map((p) => p[0]);
    const ys = pts.map((p) => p[1]);
    cx = (Math.min(...xs) + Math.max(...xs)) / 2;
    cy = (Math.min(...ys) + Math.max(...ys)) / 2;
    need = Math.max(need, (Math.max(...xs) - Math.min(...xs)) * 0.7, (Math.max(...ys) - Math.min(...ys)) * 0.7);
    if (shown && shown.region) need = Math.max(need, 1.5 * shown.region.major);
  }
  POINTING.span = POINTING.span === null ? need : Math.max(need, POINTING.span * 0.98);
  const scale = Math.min(w, h) / (2 * POINTING.span);
  const X = (u) => w / 2 + (u - cx) * scale;
  const Y = (v) => h / 2 - (v - cy) * scale; // ahead is up
  drawGrid(g, w, h, X, Y, scale, cx, cy);
  if (track.length > 1) {
    g.lineWidth = 2;
    for (let k = 1; k < track.length; k++) {
      const age = track[k][0];
      g.strokeStyle = `rgba(31, 95, 191, ${Math.max(0.15, 1 - age)})`;
      g.beginPath();
      g.moveTo(X(track[k - 1][1]), Y(track[k - 1][2]));
      g.lineTo(X(track[k][1]), Y(track[k][2]));
      g.stroke();
    }
  }
  if (pair && pair.point) {
    const [u, v] = pair.point;
    if (pair.region) {
      g.save();
      g.translate(X(u), Y(v));
      g.rotate((-pair.region.angle_deg * Math.PI) / 180);
      g.beginPath();
      g.ellipse(0, 0, Math.max(1, pair.region.major * scale), Math.max(1, pair.region.minor * scale), 0, 0, 2 * Math.PI);
      g.fillStyle = "rgba(214, 39, 40, 0.15)";
      g.fill();
      g.strokeStyle = "#d62728";
      g.lineWidth = 1.5;
      g.stroke();
      g.restore();
    }
    g.fillStyle = "#d62728";
    g.beginPath();
    g.arc(X(u), Y(v), 5, 0, 2 * Math.PI);
    g.fill();
  } else if (pair) {
    g.fillStyle = "rgba(255, 255, 255, 0.75)";
    g.fillRect(0, h / 2 - 16, w, 32);
    g.fillStyle = pair.status === "near_singular" ? "#8a5a00" : "#a61b1b";
    g.font = "bold 14px 'twopose sans', sans-serif";
    g.textAlign = "center";
    g.fillText(pair.status === "near_singular" ? "near-singular: no point" : "no point", w / 2, h / 2 + 5);
  }
}

function drawGrid(g, w, h, X, Y, scale, cx, cy) {
  // A line every 1, 2 or 5 times a power of ten, some 40 px apart; the cameras' foot marked.
  const raw = 40 / scale;
  const p = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map((m) => m * p).find((m) => m >= raw);
  g.strokeStyle = "#e3e7ec";
  g.lineWidth = 1;
  const half = w / scale;
  for (let u = Math.floor((cx - half) / step) * step; u <= cx + half; u += step) {
    g.beginPath();
    g.moveTo(X(u), 0);
    g.lineTo(X(u), h);
    g.stroke();
  }
  for (let v = Math.floor((cy - half) / step) * step; v <= cy + half; v += step) {
    g.beginPath();
    g.moveTo(0, Y(v));
    g.lineTo(w, Y(v));
    g.stroke();
  }
  g.fillStyle = "#5b6673";
  g.font = "11px 'twopose sans', sans-serif";
  g.textAlign = "left";
  g.fillText(`grid ${step} ${POINTING.status.units || ""}; ahead is up`, 6, h - 6);
  const foot = [X(0), Y(0)];
  if (foot[0] > 0 && foot[0] < w && foot[1] > 0 && foot[1] < h) {
    g.beginPath();
    g.moveTo(foot[0], foot[1] - 7);
    g.lineTo(foot[0] - 6, foot[1] + 5);
    g.lineTo(foot[0] + 6, foot[1] + 5);
    g.closePath();
    g.fill();
  }
}

function buildPanel(panel) {
  // The panel's parts, the same on every page that has its place (#pointing).
  const heading = el("h2", "Pointing, live ");
  heading.append(el("span", "", "aside"));
  heading.lastChild.id = "pointing-aside";
  const words = el("div", "no pair running", "pointing-words idle");
  words.title = "pointing needs two cameras: --source pair:A,B with --pair PAIR.toml";
  Object.assign(words, {id: "pointing-conditioning", role: "status"});
  words.dataset.testid = "pointing-conditioning";
  words.setAttribute("aria-live", "polite");
  const box = el("div", null, "hidden");
  box.id = "pointing-box";
  const canvas = el("canvas");
  canvas.id = "pointing-canvas";
  canvas.dataset.testid = "pointing-canvas";
  box.append(canvas);
  const numbers = el("div", null, "small");
  numbers.id = "pointing-numbers";
  numbers.dataset.testid = "pointing-numbers";
  for (const part of ["pointing-where", "pointing-timing"]) {
    const span = el("span");
    span.id = part;
    numbers.append(span);
  }
  panel.append(heading, words, box, numbers);
  // On the recording console, no pair running is said in the header, in one line (the
  // panel's room is the top view's and the map's then).
  if ($("topview") && $("phase")) {
    const badge = el("span", null, "hidden");
    badge.id = "pointing-badge";
    badge.dataset.testid = "pointing-badge";
    $("phase").before(badge);
  }
}

function startPointing() {
  const panel = $("pointing");
  if (!panel) return;
  buildPanel(panel);
  renderPointing();
  syncClock(10);
  setInterval(() => syncClock(3), CLOCK_EVERY_MS);
  const source = new EventSource("/api/pointing");
  source.onmessage = pointingMessage;
  source.onerror = () => {
    POINTING.status = {running: false, words: "the recorder cannot be reached (reconnecting...)"};
    renderPointing();
  };
}

if (document.readyState === "loading") {
  document.addEventListener("DOMContentLoaded", startPointing);
} else {
  startPointing();
}
