// The operator's console (recorder/console.html): polls GET /api/state and sends the
// operator's answers as same-origin JSON POSTs. Every text goes in by textContent; the
// page never builds HTML from data. No inline script or style (the page's
// Content-Security-Policy allows scripts from this origin only).
"use strict";

const $ = (id) => document.getElementById(id);
const POLL_MS = 250;
const DECISIONS = {a: "accept", A: "accept_anyway", r: "redo", u: "undo"};
const BUTTON_OF = {accept: "accept", accept_anyway: "accept-anyway", redo: "redo", undo: "undo"};
const POSE_INPUTS = {x: "pose-x", y: "pose-y", z: "pose-z", rotation: "pose-rotation"};

let state = null;
let connected = false;
let setupBuilt = false;
let wasWaiting = null; // what the recorder waited for at the last poll
let dismissedRefusal = 0; // the recorder's refusals up to this seq are answered
let localRefusal = null; // {control, message}: a decision the server refused at once
let quitAsked = false;
let busy = false;
const drawn = {}; // what each part of the page was last drawn from (JSON), to redraw on change

// --------------------------------------------------------------------------- helpers

function el(tag, text, className) {
  const e = document.createElement(tag);
  if (text !== undefined && text !== null) e.textContent = String(text);
  if (className) e.className = className;
  return e;
}

function show(element, visible) {
  element.classList.toggle("hidden", !visible);
}

function setText(element, text) {
  const value = text === undefined || text === null ? "" : String(text);
  if (element.textContent !== value) element.textContent = value;
}

function changed(part, value) {
  const key = JSON.stringify(value);
  if (drawn[part] === key) return false;
  drawn[part] = key;
  return true;
}

function num(v, digits = 3) {
  if (v === null || v === undefined || !Number.isFinite(v)) return "–";
  return String(Number(v.toFixed(digits)));
}

function fixed(v, digits) {
  return v === null || v === undefined || !Number.isFinite(v) ? "–" : v.toFixed(digits);
}

async function post(path, body) {
  let response;
  let answer = {};
  try {
    response = await fetch(path, {
      method: "POST",
      headers: {"Content-Type": "application/json"},
      body: JSON.stringify(body),
      credentials: "same-origin",
      cache: "no-store",
    });
  } catch (err) {
    return {ok: false, error: "the recorder cannot be reached (" + err.message + ")", errors: {}};
  }
  try {
    answer = await response.json();
  } catch (err) {
    answer = {};
  }
  if (response.ok) return {ok: true, errors: {}};
  const error = typeof answer.error === "string" && answer.error
    ? answer.error : "refused by the recorder (HTTP " + response.status + ")";
  const errors = answer.errors && typeof answer.errors === "object" ? answer.errors : {};
  return {ok: false, error, errors};
}

async function act(action) {
  // One operator action at a time: a double click does not send twice.
  if (busy) return;
  busy = true;
  try {
    await action();
  } finally {
    busy = false;
  }
  await poll();
}

// --------------------------------------------------------------------------- setup

function buildSetup(fields) {
  const box = $("setup-fields");
  box.replaceChildren();
  for (const f of fields) {
    const cell = el("div", null, "cell" + (f.kind === "check" ? " check" : ""));
    cell.id = "cell-" + f.name;
    cell.dataset.methods = f.methods.join(" ");
    let input;
    if (f.kind === "choice") {
      input = el("select");
      if (!f.value) {
        const choose = el("option", "choose...");
        choose.value = "";
        input.append(choose);
      }
      for (const option of f.options) {
        const o = el("option", option);
        o.value = option;
        input.append(o);
      }
      input.value = f.value || "";
      input.disabled = f.given;
    } else if (f.kind === "check") {
      input = el("input");
      input.type = "checkbox";
      input.checked = ["y", "yes", "true", "on", "1"].includes(String(f.value).toLowerCase());
      input.disabled = f.given;
    } else {
      input = el("input");
      input.type = "text";
      input.autocomplete = "off";
      input.value = f.value || "";
      input.readOnly = f.given;
    }
    input.id = "f-" + f.name;
    input.dataset.testid = "field-" + f.name;
    input.name = f.name;
    const name = el("label", f.label, "name");
    name.htmlFor = input.id;
    if (f.kind === "check") cell.append(input, name);
    else cell.append(name, input);
    if (f.given) {
      // Where a fixed value comes from: the command line, or the continued session's file.
      const from = f.from || "the command line";
      const said = from === "the command line" ? "from the command line (fixed for this session)"
        : "from " + from + " (the session's setup, fixed)";
      const note = el("span", said, "note given");
      note.dataset.testid = "from-" + f.name;
      cell.append(note);
    } else if (f.from) {
      // Filled in from the continued session, but this file's own to change.
      const whose = f.name === "operator" ? "operator" : "stop rule";
      const note = el("span", "from " + f.from + ": its " + whose + "; this file's own, change it if it differs", "note given");
      note.dataset.testid = "from-" + f.name;
      cell.append(note);
    } else if (f.value && ["focal", "principal", "ground_height"].includes(f.name)) {
      // Said beside the thesis' value only: once changed, the field holds the operator's.
      const note = el("span", "the thesis' rig: change it if yours differs", "note");
      note.id = "default-" + f.name;
      note.dataset.default = f.value;
      cell.append(note);
      input.addEventListener("input", () => show(note, input.value.trim() === note.dataset.default));
    }
    const error = el("span", "", "field-error hidden");
    error.id = "error-" + f.name;
    error.dataset.testid = "field-error-" + f.name;
    error.setAttribute("role", "alert");
    cell.append(error);
    box.append(cell);
  }
  const method = $("f-method");
  if (method) method.addEventListener("change", applyMethod);
  const units = $("f-units");
  if (units) units.addEventListener("change", applyUnits);
  applyMethod();
  setupBuilt = true;
}

function applyMethod() {
  // The chosen method's fields only; before one is chosen, those every method has.
  const method = $("f-method") ? $("f-method").value : "";
  const all = $("f-method") ? $("f-method").options.length - ($("f-method").options[0].value ? 0 : 1) : 0;
  for (const cell of $("setup-fields").children) {
    const methods = cell.dataset.methods.split(" ");
    show(cell, method ? methods.includes(method) : methods.length >= all);
  }
}

function applyUnits() {
  // The thesis' ground height is in inches: offered for inches only, never converted.
  const height = $("f-ground_height");
  if (!height || height.readOnly) return;
  const inches = $("f-units").value === "in";
  if (!inches && height.value === "9.625") height.value = "";
  if (inches && !height.value) height.value = "9.625";
  const note = $("default-ground_height");
  if (note) show(note, height.value.trim() === note.dataset.default);
}

function clearErrors(names) {
  for (const name of names) {
    const error = $("error-" + name);
    if (error) {
      setText(error, "");
      show(error, false);
    }
    const input = name in POSE_INPUTS ? $(POSE_INPUTS[name]) : $("f-" + name);
    if (input) input.classList.remove("invalid");
  }
}

function showErrors(errors, inputOf) {
  // Each refusal next to its field; returns the ones that have no field shown.
  const left = [];
  for (const [name, message] of Object.entries(errors)) {
    const error = $("error-" + name);
    const input = inputOf(name);
    if (error && input && input.getClientRects().length) {
      setText(error, message);
      show(error, true);
      input.classList.add("invalid");
    } else {
      left.push(message);
    }
  }
  return left;
}

async function submitSetup() {
  if (!state || state.phase !== "setup") return;
  const form = {};
  const names = [];
  for (const input of $("setup-fields").querySelectorAll("input, select")) {
    names.push(input.name);
    const visible = input.getClientRects().length > 0;
    if (input.type === "checkbox") form[input.name] = visible && input.checked ? "yes" : "";
    else form[input.name] = visible ? input.value.trim() : "";
  }
  clearErrors(names);
  show($("setup-refusal"), false);
  const answer = await post("/api/setup", form);
  if (answer.ok) return;
  const left = showErrors(answer.errors, (name) => $("f-" + name));
  if (left.length || !Object.keys(answer.errors).length) {
    setText($("setup-refusal"), left.length ? left.join("; ") : answer.error);
    show($("setup-refusal"), true);
  }
}

// --------------------------------------------------------------------------- pose, decision

async function submitPose() {
  if (!state || state.waiting !== "pose") return;
  const body = {};
  for (const [name, id] of Object.entries(POSE_INPUTS)) body[name] = $(id).value.trim();
  clearErrors(Object.keys(POSE_INPUTS));
  show($("pose-refusal"), false);
  dismissRefusals();
  const answer = await post("/api/pose", body);
  if (answer.ok) return;
  const left = showErrors(answer.errors, (name) => $(POSE_INPUTS[name]));
  if (left.length || !Object.keys(answer.errors).length) {
    setText($("pose-refusal"), left.length ? left.join("; ") : answer.error);
    show($("pose-refusal"), true);
  }
}

function dismissRefusals() {
  localRefusal = null;
  if (state && state.refusal && state.refusal.seq) dismissedRefusal = state.refusal.seq;
}

async function decide(choice) {
  if (!state || state.waiting !== "decision") return;
  dismissRefusals();
  render();
  const answer = await post("/api/decide", {decision: choice});
  if (!answer.ok) localRefusal = {control: choice, message: answer.errors[choice] || answer.error};
}

async function addNote() {
  const text = $("note-text").value.trim();
  show($("note-refusal"), false);
  const answer = await post("/api/note", {text});
  if (answer.ok) {
    $("note-text").value = "";
    $("note-text").blur(); // the keys decide again: the next "a" accepts, it types nothing
  } else {
    setText($("note-refusal"), answer.error);
    show($("note-refusal"), true);
  }
}

function askQuit(ask) {
  quitAsked = ask;
  show($("quit-ask"), ask);
  if (ask) $("quit-confirm").focus();
}

async function quit() {
  askQuit(false);
  dismissRefusals();
  const answer = await post("/api/decide", {decision: "quit"});
  if (!answer.ok) localRefusal = {control: "quit", message: answer.error};
}

// --------------------------------------------------------------------------- drawing

function render() {
  if (!state) return;
  const s = state;
  const main = $("main");
  main.className = "phase-" + s.phase;
  document.body.classList.toggle("stopped", !connected);
  setText($("out"), s.out);
  const phase = {setup: "setting up", recording: "recording", done: "finished", failed: "stopped"}[s.phase] || s.phase;
  setText($("phase"), connected || s.phase === "done" ? phase : "not answering");
  renderStatus(s);

  if (s.phase === "setup" && !setupBuilt && s.setup_fields.length) buildSetup(s.setup_fields);
  if (s.continuing) {
    setText($("setup-aside"), "the setup of " + s.continuing.file + ", kept; the operator and the stop rule are this file's");
  }
  show($("setup"), s.phase === "setup");
  $("setup-submit").disabled = !connected;

  renderCapture(s);
  renderPose(s);
  renderDecision(s);
  renderPoses(s);
  renderResults(s);
  wasWaiting = s.waiting;
}

function renderStatus(s) {
  const status = $("status");
  let level = s.level || "info";
  let message = s.message;
  if (!connected && s.phase === "done") {
    level = "done";
    message = "the session is finished and the recorder has stopped: the file is closed";
  } else if (!connected && s.phase === "setup") {
    level = "error";
    message = "the recorder stopped (or cannot be reached) before the session started: " +
      "nothing was recorded. Still trying to reach it...";
  } else if (!connected) {
    // Killed, crashed or stopped: the page cannot tell which, so it says what salvages
    // the file (harmless after Ctrl-C, which closes it).
    level = "error";
    message = "the recorder stopped: run " + s.recover + " to salvage what was accepted " +
      "(not needed if it was stopped with Ctrl-C: that closes the file). The controls are " +
      "off; still trying to reach it...";
  } else if (s.phase === "recording" && s.computing) {
    level = "info"; // working, not a warning: the last result's colour is its own, below
    message = s.computing + "...";
  } else if (s.phase === "failed") {
    level = "error";
  } else if (s.phase === "done") {
    level = "done";
    message = "the session is finished: the file is closed; its summary is below";
  }
  setText(status, message);
  status.className = "level-" + level;
  setText($("live-error"), s.live_error);
  show($("live-error"), !!s.live_error);
  if (changed("notices", s.notices)) {
    $("notices").replaceChildren(...(s.notices || []).map((n) => el("li", "note: " + n)));
    show($("notices"), !!(s.notices || []).length);
  }
  renderSetupSummary(s);
}

function renderSetupSummary(s) {
  // What is being recorded stays in view: method, units, camera, ground truth.
  const shown = s.setup || {};
  if (!changed("setup-summary", shown)) return;
  const box = $("session-setup");
  show(box, !!shown.method);
  if (!shown.method) return;
  const units = shown.units;
  const parts = [["method", shown.method], ["units", units], ["camera", shown.camera]];
  const truth = (shown.truth || []).map((p) => "(" + p.map((v) => num(v)).join(", ") + ")");
  if (shown.board) parts.push(["board", shown.board]);
  else parts.push(["ground truth", truth.length ? truth.join(" to ") + " " + units : "none typed"]);
  if (shown.ground_height !== null && shown.ground_height !== undefined) {
    parts.push(["ground height", num(shown.ground_height) + " " + units]);
  }
  if (shown.rig) parts.push(["rig", shown.rig]);
  if (shown.operator) parts.push(["operator", shown.operator]);
  if (shown.stop_rule) parts.push(["stop rule", shown.stop_rule]);
  if (shown.continues) parts.push(["continues", shown.continues]);
  const children = [];
  parts.forEach(([name, value], i) => {
    if (i) children.push(document.createTextNode(" · "));
    children.push(el("span", name + " "), el("b", value));
  });
  box.replaceChildren(...children);
}

let capturedAt = ""; // the trial and pose whose capture the frames table shows

function renderCapture(s) {
  const live = $("live");
  const kept = keepLastFrame(live);
  // Stopped or unreachable: the last frame stays (the stream's image goes blank when the
  // connection drops), greyed, under one caption.
  const frozen = !connected && s.phase !== "setup";
  show(live, !frozen || !kept);
  show($("live-last"), frozen && kept);
  let note = "";
  if (s.phase === "setup") note = "the camera is shown here once the session starts";
  else if (s.phase === "recording" && connected && !live.naturalWidth) note = "waiting for the camera's first frame...";
  // The table is this pose's capture while it is taken and decided; afterwards it is
  // the last capture's, and says so.
  const of = s.frames_of || {};
  capturedAt = of.trial ? "trial " + of.trial + " pose " + of.pose : "";
  const current = s.phase === "recording" && s.waiting !== "pose";
  setText($("frames-title"), !s.frames.length ? "This pose's capture, frame by frame"
    : current ? "This capture (" + capturedAt + "), frame by frame"
    : "The last capture" + (capturedAt ? " (" + capturedAt + ")" : "") + ", frame by frame");
  setText($("live-note"), note);
  show($("live-note"), !!note);
  let caption = "";
  if (s.phase === "done") caption = "the last frame: the session is finished, the camera is off";
  else if (s.phase === "failed") caption = "the last frame: the session stopped";
  else if (frozen) caption = kept ? "the last frame before the recorder stopped" : "the recorder stopped before the camera's first frame";
  setText($("live-caption"), caption);
  show($("live-caption"), !!caption);
  const n = s.capture.n_frames || 0;
  $("progress").max = n || 1;
  $("progress").value = Math.min(s.capture.frame || 0, n || 1);
  setText($("progress-text"), n ? "frame " + s.capture.frame + " of " + n : "");
  setText($("last-capture"), s.last_capture ? "last capture: " + s.last_capture : "");
  if (changed("frames-head", s.method === "board")) {
    setText($("camera-aside"), s.method === "board"
      ? "each frame's board corners are looked for (nothing drawn)"
      : "detection drawn: green found, red turned down");
    const head = $("frames-table").tHead.rows[0];
    for (const th of head.cells) show(th, s.method !== "board" || th.cellIndex < 2);
    head.cells[1].textContent = s.method === "board" ? "the board" : "obj.";
  }
  if (changed("frames", s.frames)) {
    const body = $("frames-table").tBodies[0];
    body.replaceChildren(...s.frames.map(frameRow));
  }
  const avg = $("pose-average");
  const a = s.average;
  if (!a) {
    setText(avg, s.frames.length ? "" : "no capture yet");
    avg.classList.remove("none");
  } else if (!a.found) {
    setText(avg, "pose average: none (the target was found in 0 of " + a.n_frames + " frames)");
    avg.classList.add("none");
  } else {
    const c = a.centroid_px || [];
    const sd = a.centroid_std_px || [];
    setText(avg,
      "pose average over " + a.n_used + " of " + a.n_frames + " frames: centroid (" +
      fixed(c[0], 1) + ", " + fixed(c[1], 1) + ") px ± (" + fixed(sd[0], 1) + ", " +
      fixed(sd[1], 1) + "), orientation " + fixed(a.theta_deg, 1) + "°");
    avg.classList.remove("none");
  }
}

// The live image's last frame, copied while the stream shows it (false: none yet).
let lastFrameSeq = -1;
function keepLastFrame(live) {
  const canvas = $("live-last");
  if (connected && live.naturalWidth && state && state.frame_seq !== lastFrameSeq) {
    lastFrameSeq = state.frame_seq;
    canvas.width = live.naturalWidth;
    canvas.height = live.naturalHeight;
    try {
      canvas.getContext("2d").drawImage(live, 0, 0);
    } catch (err) {
      return lastFrameSeq > 0; // a frame half-decoded: the one before stays
    }
  }
  return lastFrameSeq >= 0;
}

function frameRow(f) {
  const tr = el("tr");
  tr.append(el("td", f.frame));
  if (f.is_board) {
    // A board session: was the whole board found, and how much of the image it covers.
    const said = f.found
      ? "board found: " + f.board_corners + " corners, covering " + Math.round(100 * f.board_coverage) + "% of the image"
      : "not found: " + (f.reason || "the board");
    const cell = el("td", said, f.found ? "" : "no");
    cell.colSpan = 6;
    tr.append(cell);
    return tr;
  }
  if (f.found === null || f.found === undefined) {
    const none = el("td", "no live detection", "no");
    none.colSpan = 6;
    tr.append(none);
    return tr;
  }
  if (!f.found) {
    const reason = el("td", f.reason ? "not found: " + f.reason : "not found", "no");
    reason.colSpan = 5;
    tr.append(el("td", f.n_blobs), reason);
    return tr;
  }
  const c = f.centroid_px || [];
  tr.append(
    el("td", f.n_blobs),
    el("td", fixed(c[0], 1) + ", " + fixed(c[1], 1)),
    el("td", fixed(f.theta_deg, 1)),
    el("td", fixed(f.area_px, 0)),
    el("td", fixed(f.eccentricity, 2)),
    el("td", (f.line || "").replace(/^line /, "").replace(/ ([uv])\b/g, "$1"), "line"),
  );
  return tr;
}

function renderPose(s) {
  const typing = s.phase === "recording" && s.waiting === "pose";
  if (typing && wasWaiting !== "pose") {
    // A new placement: a new pose starts empty; a retyped one (after redo or undo)
    // shows what was typed for it. Never another pose's values.
    const t = (s.pose_form && s.pose_form.t) || null;
    const r = (s.pose_form && s.pose_form.r_deg) || null;
    $("pose-x").value = t ? num(t[0]) : "";
    $("pose-y").value = t ? num(t[1]) : "";
    $("pose-z").value = t ? num(t[2]) : "";
    $("pose-rotation").value = r ? r.map((v) => num(v)).join(", ") : "";
    clearErrors(Object.keys(POSE_INPUTS));
    show($("pose-refusal"), false);
  }
  for (const id of Object.values(POSE_INPUTS)) $(id).disabled = !typing || !connected;
  $("capture").disabled = !typing || !connected;
  if (typing && wasWaiting !== "pose" && !quitAsked) {
    const active = document.activeElement;
    if (!active || active === document.body || active.tagName === "BUTTON") $("pose-x").focus();
  }
  renderGuidance(s, typing);
  setText($("where"), s.trial ? "trial " + s.trial + ", pose " + s.pose + " of " + s.n_poses : "");
  setText($("units-note"), s.units ? "the camera centre on the grid, in " + s.units + "; rotation empty: 0, 0, 0" : "");
  show($("pose-form"), s.phase === "recording");
  show($("poses-box"), s.phase === "recording");
}

// The recorder's guidance: the next pose it suggests (taken into the form with g or the
// button), or the trial complete by the stop rule.
function renderGuidance(s, typing) {
  if (s.phase === "recording" && s.computing && connected) {
    // Between a decision and the next step: the suggestion is being worked out.
    show($("guidance"), true);
    $("guidance").classList.add("computing");
    setText($("guidance-text"), s.method === "board" ? "working out what the poses say of the rig..." : "computing the next pose to suggest...");
    show($("take-suggestion"), false);
    return;
  }
  $("guidance").classList.remove("computing");
  const a = s.advice && s.advice.trial === s.trial ? s.advice : null;
  // While a capture awaits its decision the advice is the last pose's: shown again after it.
  show($("guidance"), !!a && s.phase === "recording" && (typing || a.complete));
  setText($("guidance-text"), a ? a.text : "");
  const take = $("take-suggestion");
  show(take, !!(a && a.suggestion));
  take.disabled = !(typing && connected && a && a.suggestion);
}

function takeSuggestion() {
  const a = state && state.advice;
  if (!a || !a.suggestion || state.waiting !== "pose") return;
  const [x, y, z] = a.suggestion.t_grid;
  $("pose-x").value = num(x);
  $("pose-y").value = num(y);
  $("pose-z").value = num(z);
  $("pose-rotation").value = a.suggestion.r_deg.map((v) => num(v)).join(", ");
  $("capture").focus();
}

function renderDecision(s) {
  const recording = s.phase === "recording" && connected;
  const deciding = recording && s.waiting === "decision";
  show($("decision"), s.phase === "recording"); // shown, but off, while unreachable
  show($("finished"), s.phase === "done" || s.phase === "failed");
  if (changed("summary", [s.phase, s.summary, s.message])) {
    // "wrote PATH: counts" on two lines: where the file is, then what it holds.
    const text = s.phase === "done" ? s.summary : s.message;
    const m = /^(wrote .+): (\d+ trials? \(.*)$/s.exec(text || "");
    const summary = $("summary");
    if (m) summary.replaceChildren(el("span", m[1] + ":", "path"), el("span", m[2], "counts"));
    else summary.replaceChildren(el("span", text));
  }
  const failed = s.phase === "failed";
  setText($("finished").querySelector("h2"), failed ? "The session stopped" : "The session is finished");
  $("finished").classList.toggle("failed", failed);

  const few = deciding && s.shortfall === "few";
  const none = deciding && s.shortfall === "none";
  $("accept").disabled = !deciding || none;
  show($("accept-anyway"), few);
  $("accept-anyway").disabled = !few;
  $("redo").disabled = !deciding;
  $("undo").disabled = !deciding;
  $("note-add").disabled = !deciding;
  $("note-text").disabled = !deciding;
  $("quit").disabled = !recording;
  if (!recording && quitAsked) askQuit(false);

  // The refusal of a decision, under the decision buttons, the button that caused it marked.
  let refusal = localRefusal;
  const r = s.refusal || {};
  if (!refusal && r.seq && r.seq > dismissedRefusal && recording && s.waiting !== "pose") {
    refusal = {control: r.control, message: r.message};
  }
  if (!recording) refusal = null;
  const box = $("refusal");
  show(box, !!refusal);
  setText(box, refusal ? refusal.message : "");
  box.dataset.control = refusal ? refusal.control : "";
  for (const [control, id] of Object.entries(BUTTON_OF)) {
    $(id).classList.toggle("refused", !!refusal && refusal.control === control);
  }
  $("quit").classList.toggle("refused", !!refusal && refusal.control === "quit");

  // Why accept needs "anyway" or is off (the refusal says it instead when there is one).
  const shortfall = $("shortfall");
  if (refusal) {
    shortfall.className = "hidden";
  } else if (few) {
    setText(shortfall, "the target was found in fewer than half the frames: redo, or accept anyway");
    shortfall.className = "warning";
  } else if (none) {
    const what = s.method === "board" ? "the board" : "the target";
    setText(shortfall, what + " was not found in any frame: nothing to measure, so accept is off; redo");
    shortfall.className = "error";
  } else {
    shortfall.className = "hidden";
  }

  const preview = $("preview");
  const p = deciding ? s.preview : null;
  show(preview, !!p);
  setText($("preview-result"), p ? p.text : "");
  preview.classList.toggle("warned", !!p && (!!p.warning || p.outside95 || p.status !== "ok"));
  if (!deciding) {
    show($("note-refusal"), false);
  }
  if (changed("notes", s.notes)) {
    const notes = s.notes || [];
    $("notes-list").replaceChildren(...notes.map((n) => el("li", "trial " + n.trial + ": " + n.text)));
    show($("notes-list"), notes.length > 0);
  }
}

function renderPoses(s) {
  if (!changed("poses", s.poses)) return;
  const body = $("pose-list").tBodies[0];
  if (!s.poses.length) {
    const tr = el("tr");
    tr.append(el("td", "none yet", "small"));
    body.replaceChildren(tr);
    return;
  }
  body.replaceChildren(...s.poses.map((p) => {
    const tr = el("tr", null, p.state === "accepted" ? "accepted" : "awaiting");
    tr.append(
      el("td", "pose " + p.pose),
      el("td", "x " + num(p.t[0]) + ", y " + num(p.t[1]) + ", z " + num(p.t[2])),
      el("td", "rot " + p.r_deg.map((v) => num(v)).join(", ")),
      el("td", p.state, "state"),
    );
    return tr;
  }));
}

function renderResults(s) {
  const board = s.method === "board";
  show($("trials-section"), !board);
  show($("rig-section"), board && s.phase !== "setup");
  if (board) {
    const accepted = s.topview ? s.topview.cameras.length : 0;
    const box = $("rig-readiness");
    if (!accepted) {
      setText(box, "no capture has seen the board yet: the rig needs at least 3, at several distances and in two directions");
      box.className = "neutral";
    } else if (s.rig_readiness) {
      setText(box, "these " + accepted + " poses cannot determine the rig yet: " + s.rig_readiness);
      box.className = "warning";
    } else {
      setText(box, "these " + accepted + " poses can determine the rig (twopose-analyze rig); more, spread wider, narrow it");
      box.className = "ok";
    }
  }
  if (changed("results", s.results)) {
    const list = $("trials");
    list.replaceChildren(...s.results.map((r) => {
      const li = el("li", r.text);
      li.dataset.testid = "trial-result";
      li.dataset.trial = r.trial;
      if (r.status !== "ok" || r.warning || r.outside95) li.classList.add("warned");
      return li;
    }));
    if (!s.results.length) list.append(el("li", "none yet: a trial's result shows once its poses are accepted", "small"));
    $("trials-box").scrollTop = $("trials-box").scrollHeight;
  }
  const canvas = $("topview");
  const size = [canvas.clientWidth, canvas.clientHeight, window.devicePixelRatio || 1];
  const next = s.advice && s.advice.suggestion && s.topview && s.advice.trial === s.topview.trial
    ? s.advice.suggestion.t_grid : null;
  if (changed("topview", [s.topview, s.units, size, next])) drawTopView(s.topview, s.units, s.method, next);
}

// --------------------------------------------------------------------------- the top view

const COLOURS = {
  board: "#333f4d",
  camera: "#1f5fbf", ray: "#e07b00", trace: "#8e44ad", line: "#d62728",
  truth_line: "#2ca02c", estimate: "#d62728", truth: "#2ca02c", grid: "#e3e7ec", axis: "#5b6673",
};

function legendItems(view, next) {
  const kinds = new Set(view.segments.map((g) => g.kind));
  if (view.method === "board") {
    return [["camera", "▲", "camera centre (each capture that saw the board)"],
      ["board", "━", "the board (its inner corners, from above)"]];
  }
  const items = [["camera", "▲", "camera centre (each pose)"]];
  if (next) items.push(["camera", "△", "suggested next pose (g takes it)"]);
  if (kinds.has("ray")) items.push(["ray", "—", "ray through the dot, per pose"]);
  if (kinds.has("trace")) items.push(["trace", "—", "finger's plane on the ground, per pose"]);
  if (kinds.has("line")) items.push(["line", "━", "estimated line"]);
  if (kinds.has("truth_line")) items.push(["truth_line", "╌", "true line"]);
  if (view.estimate) {
    const what = view.method === "ground" ? "ground point (estimate)" : view.method === "line" ? "line's point (estimate)" : "estimate";
    items.push(["estimate", "✕", what]);
  }
  const truthWord = {ground: "true ground point", line: "true line, seen end-on", point: "true point"};
  if (view.truth) items.push(["truth", "○", truthWord[view.method] || "true point"]);
  return items;
}

function niceStep(span) {
  const raw = span / 5;
  const p = Math.pow(10, Math.floor(Math.log10(raw)));
  const m = raw / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}

function drawTopView(view, units, method, next) {
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
    const board = method === "board";
    ctx.fillText(board ? "the board and the poses" : "a trial, from above,", w / 2, h / 2 - 9);
    ctx.fillText(board ? "once a capture has seen it" : "once it has two poses", w / 2, h / 2 + 9);
    return;
  }
  setText($("topview-title"), view.method === "board" ? "the board session, from above" : "trial " + view.trial + ", from above");
  legend.replaceChildren(...legendItems(view, next).map(([kind, mark, text]) => {
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
    ctx.lineWidth = g.kind === "line" || g.kind === "board" ? 3 : 2;
    ctx.setLineDash(g.kind === "truth_line" ? [7, 5] : []);
    ctx.beginPath();
    ctx.moveTo(X(g.from[0]), Y(g.from[1]));
    ctx.lineTo(X(g.to[0]), Y(g.to[1]));
    ctx.stroke();
  }
  ctx.setLineDash([]);
  ctx.fillStyle = COLOURS.camera;
  for (const c of view.cameras) {
    const cx = X(c[0]), cy = Y(c[1]);
    ctx.beginPath(); ctx.moveTo(cx, cy - 8); ctx.lineTo(cx - 7, cy + 5); ctx.lineTo(cx + 7, cy + 5); ctx.closePath(); ctx.fill();
  }
  if (suggested) { // the suggested next pose: a hollow camera, dashed
    const cx = X(suggested[0]), cy = Y(suggested[1]);
    ctx.strokeStyle = COLOURS.camera; ctx.lineWidth = 2; ctx.setLineDash([3, 2]);
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

// --------------------------------------------------------------------------- polling, input

let polling = false;

async function poll() {
  if (polling) return;
  polling = true;
  try {
    const response = await fetch("/api/state", {cache: "no-store", credentials: "same-origin"});
    if (!response.ok) throw new Error("HTTP " + response.status);
    state = await response.json();
    connected = true;
  } catch (err) {
    // Lost: the header and the status say what happened (and how to salvage the file); on
    // a small screen the operator may be scrolled down to the buttons: back to the top.
    if (connected) window.scrollTo({top: 0});
    connected = false;
  } finally {
    polling = false;
  }
  if (!state) {
    setText($("status"), "cannot reach the recorder; retrying...");
    $("status").className = "level-error";
    return;
  }
  try {
    render();
  } catch (err) {
    // A drawing bug must not leave the operator blind: say it where the status is.
    setText($("status"), state.message + " (the page could not draw everything: " + err.message + ")");
  }
}

async function loop() {
  await poll();
  setTimeout(loop, POLL_MS);
}

function typingIn(target) {
  if (target instanceof HTMLSelectElement || target instanceof HTMLTextAreaElement) return true;
  return target instanceof HTMLInputElement && target.type !== "checkbox" && !target.disabled;
}

document.addEventListener("keydown", (event) => {
  if (event.ctrlKey || event.metaKey || event.altKey || event.repeat) return;
  if (event.key === "Escape" && quitAsked) {
    askQuit(false);
    return;
  }
  if (!typingIn(event.target) && event.key === "g" && state && state.waiting === "pose") {
    event.preventDefault();
    takeSuggestion();
    return;
  }
  if (typingIn(event.target) || !state || state.waiting !== "decision" || quitAsked) return;
  const choice = DECISIONS[event.key];
  if (!choice) return;
  event.preventDefault();
  act(() => decide(choice));
});

$("setup-form").addEventListener("submit", (event) => {
  event.preventDefault();
  act(submitSetup);
});
$("pose-form").addEventListener("submit", (event) => {
  event.preventDefault();
  act(submitPose);
});
for (const [choice, id] of Object.entries(BUTTON_OF)) {
  $(id).addEventListener("click", () => act(() => decide(choice)));
}
$("note-add").addEventListener("click", () => act(addNote));
$("take-suggestion").addEventListener("click", takeSuggestion);
for (const id of ["pose-x", "pose-y", "pose-z", "pose-rotation"]) {
  // A pose is numbers: "g" in its fields takes the suggestion instead of typing a letter.
  $(id).addEventListener("keydown", (event) => {
    if (event.key === "g" && !event.ctrlKey && !event.metaKey && !event.altKey) {
      event.preventDefault();
      takeSuggestion();
    }
  });
}
$("note-text").addEventListener("keydown", (event) => {
  if (event.key === "Enter") {
    event.preventDefault();
    act(addNote);
  }
});
$("quit").addEventListener("click", () => askQuit(true));
$("quit-cancel").addEventListener("click", () => askQuit(false));
$("quit-confirm").addEventListener("click", () => act(quit));
window.addEventListener("resize", () => state && renderResults(state));

window.addEventListener("load", () => {
  $("live").src = "/stream.mjpg"; // after load: a never-ending stream must not hold the load
  loop();
});
