// The operator's console (recorder/console/page/index.html): polls GET /api/state and sends the
// operator's answers as same-origin JSON POSTs. No inline script or style (the page's
// Content-Security-Policy allows scripts from this origin only). What differs by method
// (panels, headings, words) comes with the state (its "page"): the page names no method.
// The helpers, the setup form, the camera panel and the top view are in util.js,
// setup.js, capture.js, topview.js and stream.js, loaded before this one.
"use strict";

const POLL_MS = 250;
const DECISIONS = {a: "accept", A: "accept_anyway", r: "redo", u: "undo"};
const BUTTON_OF = {accept: "accept", accept_anyway: "accept-anyway", redo: "redo", undo: "undo"};
const POSE_INPUTS = {x: "pose-x", y: "pose-y", z: "pose-z", rotation: "pose-rotation"};

let state = null;
let connected = false;
let setupBuilt = false;
let wasWaiting = null; // what the recorder waited for at the last poll
let newPlacement = false; // the recorder asks for a pose anew: the form is filled once shown
let dismissedRefusal = 0; // the recorder's refusals up to this seq are answered
let localRefusal = null; // {control, message, at}: a decision the server refused at once

// Which step of the recording a refusal answers (the decision offered, or none): a refusal
// is shown while that step lasts, never under the next one (it would no longer be true).
function stepOf(s) {
  return s ? s.offer + "/" + s.waiting : "";
}
let quitAsked = false;
let busy = false;
// An answer on its way to the recorder ({what, words}): its controls are off and the
// status says it was sent, until the state after it is polled (so a second click meets
// a button that is off, under a status that does not offer it).
let sent = null;

async function act(action, control) {
  // One operator action at a time: the controls are off while one is sent, and a key
  // pressed meanwhile is refused in words, never dropped.
  if (busy) {
    sayBusy(control);
    return;
  }
  busy = true;
  if (state) render();
  try {
    await action();
  } finally {
    busy = false;
  }
  await freshPoll();
  sent = null;
  if (state) render();
}

function sayBusy(control) {
  const message = "not now: your last answer is still on its way to the recorder";
  if (control === "note") {
    setText($("note-refusal"), message);
    show($("note-refusal"), true);
    return;
  }
  localRefusal = {control, message, at: stepOf(state)};
  if (state) render();
}

// --------------------------------------------------------------------------- pose, decision

async function submitPose() {
  if (!state || state.waiting !== "pose") return;
  const body = {};
  for (const [name, id] of Object.entries(POSE_INPUTS)) body[name] = $(id).value.trim();
  clearErrors(Object.keys(POSE_INPUTS));
  show($("pose-refusal"), false);
  dismissRefusals();
  sending("pose", "sent, to be captured");
  const answer = await post("/api/pose", body);
  if (answer.ok) return;
  sent = null; // refused: nothing changed, the form is the operator's again
  render();
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

// Whether the state offers this decision now (its button is on exactly then).
function offered(s, choice) {
  return !!s && connected && !sent && s.phase === "recording" && s.waiting === "decision" &&
    (s.offers || []).includes(choice);
}

async function decide(choice) {
  // An offered decision is sent and its buttons go off at once; one not offered (a key
  // pressed while the recorder captures or computes) is sent too, and the recorder says
  // in words why it cannot take it.
  if (!state) return;
  dismissRefusals();
  if (offered(state, choice)) sending(choice, choice.replace("_", " ") + " sent");
  else render();
  // The offer it answers (0: none was shown): never taken for a capture that ended after.
  const offer = state.waiting === "decision" ? state.offer : 0;
  const answer = await post("/api/decide", {decision: choice, offer: String(offer)});
  if (answer.ok) return;
  sent = null; // refused: the decision is still the operator's
  localRefusal = {control: choice, message: answer.errors[choice] || answer.error, at: stepOf(state)};
  render();
}

// Every answer sent turns the controls off, the status saying so, until it is answered.
function sending(what, words) {
  sent = {what, words: (state && state.trial ? "trial " + state.trial + " pose " + state.pose + ": " : "") + words};
  render();
}

async function addNote() {
  const text = $("note-text").value.trim();
  show($("note-refusal"), false);
  sending("note", "note sent");
  const answer = await post("/api/note", {text});
  if (answer.ok) {
    $("note-text").value = "";
    $("note-text").blur(); // the keys decide again: the next "a" accepts, it types nothing
  } else {
    sent = null;
    setText($("note-refusal"), answer.error);
    show($("note-refusal"), true);
    render();
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
  sending("quit", "quit sent");
  const answer = await post("/api/decide", {decision: "quit"});
  if (answer.ok) return;
  sent = null;
  localRefusal = {control: "quit", message: answer.error, at: stepOf(state)};
  render();
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
  $("setup-submit").disabled = !connected || busy;

  renderCapture(s);
  renderPose(s);
  renderDecision(s);
  renderPoses(s);
  renderResults(s);
  renderStream(s); // stream.js: a pair's stream trials (none for one camera)
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
  } else if (s.phase === "recording" && sent) {
    level = "info";
    message = sent.words + "...";
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
    const notices = (s.notices || []).map((n) => "note: " + n);
    $("notices").replaceChildren(...notices.map((n) => el("li", n)));
    $("notices").title = notices.join("\n");
    show($("notices"), !!notices.length);
  }
  renderSetupSummary(s);
}

function renderPose(s) {
  // A new placement is the recorder's asking anew (not a refused pose given back, nor the
  // form coming back after a sent answer): its form is filled the first time it is on.
  if (s.phase === "recording" && s.waiting === "pose" && wasWaiting !== "pose") newPlacement = true;
  const typing = s.phase === "recording" && s.waiting === "pose" && !sent;
  const placing = typing && newPlacement;
  if (placing) {
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
  if (placing && !quitAsked) {
    const active = document.activeElement;
    if (!active || active === document.body || active.tagName === "BUTTON") $("pose-x").focus();
  }
  if (placing) newPlacement = false;
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
    setText($("guidance-text"), s.page.computing);
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
  const deciding = recording && s.waiting === "decision" && !sent;
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
  // Each decision's button is on exactly while the state offers it (the status says so).
  for (const [choice, id] of Object.entries(BUTTON_OF)) $(id).disabled = !offered(s, choice);
  show($("accept-anyway"), deciding && (s.offers || []).includes("accept_anyway"));
  $("note-add").disabled = !deciding || busy;
  $("note-text").disabled = !deciding;
  $("quit").disabled = !recording || !!sent;
  $("quit-confirm").disabled = busy;
  if (!recording && quitAsked) askQuit(false);

  // The refusal of a decision, under the decision buttons, the button that caused it marked.
  if (localRefusal && localRefusal.at !== stepOf(s)) localRefusal = null; // the step moved on
  let refusal = localRefusal;
  const r = s.refusal || {};
  // a stream trial's start, touch and end are said next to their own buttons (stream.js),
  // not twice (a new user's r7 K5)
  const streamControl = ["start", "touch", "end"].includes(r.control);
  if (!refusal && r.seq && r.seq > dismissedRefusal && recording && s.waiting !== "pose" &&
      !streamControl) {
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
    setText(shortfall, s.page.sought + " was not found in any frame: nothing to measure, so accept is off; redo");
    shortfall.className = "error";
  } else {
    shortfall.className = "hidden";
  }

  const preview = $("preview");
  const p = deciding ? s.preview : null;
  show(preview, !!p);
  setText($("preview-result"), p ? p.text : "");
  preview.classList.toggle("warned", !!p && (!!p.warning || p.outside95 || p.flagged || p.status !== "ok"));
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
  const rig = s.page.reports_rig; // a board session: the rig's readiness, no trial result
  show($("trials-section"), !rig);
  show($("rig-section"), rig && s.phase !== "setup");
  if (rig) {
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
      if (r.status !== "ok" || r.warning || r.outside95 || r.flagged) li.classList.add("warned");
      return li;
    }));
    if (!s.results.length) list.append(el("li", "none yet: a trial's result shows once its poses are accepted", "small"));
    $("trials-box").scrollTop = $("trials-box").scrollHeight;
  }
  // The map of the next pose's predicted regions, under the top view: this trial's, while
  // its next pose is typed (as the suggestion), drawn first: showing it resizes the top view.
  const a = s.advice && s.advice.trial === s.trial && !s.advice.complete ? s.advice : null;
  const typing = s.phase === "recording" && s.waiting === "pose" && !s.computing;
  const map = a && typing ? a.map : null;
  const mapNext = map && a.suggestion ? a.suggestion.t_grid : null;
  const mapCanvas = $("regionmap");
  const mapSize = [mapCanvas.clientWidth, mapCanvas.clientHeight, window.devicePixelRatio || 1];
  if (changed("regionmap", [map, mapNext, mapSize])) drawRegionMap(map, mapNext);
  const canvas = $("topview");
  const size = [canvas.clientWidth, canvas.clientHeight, window.devicePixelRatio || 1];
  const next = s.advice && s.advice.suggestion && s.topview && s.advice.trial === s.topview.trial
    ? s.advice.suggestion.t_grid : null;
  if (changed("topview", [s.topview, s.units, size, next, s.page])) drawTopView(s.topview, s.units, s.page, next);
}

// --------------------------------------------------------------------------- polling, input

let polling = null; // the poll under way (a promise), shared by whoever asks meanwhile

function poll() {
  if (!polling) polling = pollOnce().finally(() => { polling = null; });
  return polling;
}

async function freshPoll() {
  // The state after an answer: a poll already under way may have left before the answer
  // was taken, so it is waited for and another is made.
  if (polling) await polling;
  await poll();
}

async function pollOnce() {
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
  if (typingIn(event.target) || !state || state.phase !== "recording" || !connected || quitAsked) return;
  const choice = DECISIONS[event.key];
  if (!choice) return;
  event.preventDefault();
  // A decision by its key, offered or not: the recorder takes it or says why not.
  act(() => decide(choice), choice);
});

$("setup-form").addEventListener("submit", (event) => {
  event.preventDefault();
  act(submitSetup, "setup");
});
$("pose-form").addEventListener("submit", (event) => {
  event.preventDefault();
  act(submitPose, "capture");
});
for (const [choice, id] of Object.entries(BUTTON_OF)) {
  $(id).addEventListener("click", () => act(() => decide(choice), choice));
}
// The session's notes on one line until opened (a click, or Enter on the focused line).
function toggleNotices() {
  const open = $("notices").classList.toggle("open");
  $("notices").setAttribute("aria-expanded", String(open));
}
$("notices").addEventListener("click", toggleNotices);
$("notices").addEventListener("keydown", (e) => {
  if (e.key === "Enter" || e.key === " ") {
    e.preventDefault();
    toggleNotices();
  }
});
$("note-add").addEventListener("click", () => act(addNote, "note"));
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
    act(addNote, "note");
  }
});
$("quit").addEventListener("click", () => askQuit(true));
$("quit-cancel").addEventListener("click", () => askQuit(false));
$("quit-confirm").addEventListener("click", () => act(quit, "quit"));
window.addEventListener("resize", () => state && renderResults(state));

window.addEventListener("load", () => {
  $("live").src = "/stream.mjpg"; // after load: a never-ending stream must not hold the load
  loop();
});
