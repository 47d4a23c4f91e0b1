// A pair's stream trials in the console (recorder/console/stream_driver.py): start trial,
// touch at a grid point (the moment the button is pressed is the touch's time), end trial;
// stop is the page's quit. Shown only when the state has a "stream" (new --pair --ui); the
// one camera's pose form and decision buttons are hidden then. Loaded before main.js,
// whose render() calls renderStream(s).
"use strict";

const STREAM_INPUTS = {x: "stream-x", y: "stream-y", z: "stream-z"};
// A start, touch or end the server refused at once ({message, at}): said next to its
// button until the step moves on or the operator acts again (the next state's render
// hid it at once: a new user's r7 K4, `1,455` and `1e3` dropped without a word).
let streamRefusal = null;

function renderStream(s) {
  const stream = s.stream;
  const wasPair = document.body.classList.contains("two-cameras");
  document.body.classList.toggle("two-cameras", !!stream);
  // the pointing panel stands on a pair's page: drawn again when the page learns it is one
  // (its own status may have come first, and an idle pair sends no other)
  if (wasPair !== !!stream && typeof renderPointing === "function" && $("pointing-conditioning")) {
    renderPointing();
  }
  show($("stream"), !!stream && s.phase === "recording");
  if (!stream) return;
  const recording = s.phase === "recording" && connected && !sent && !busy;
  $("stream-start").disabled = !recording || s.waiting !== "trial";
  $("stream-touch").disabled = !recording || s.waiting !== "streaming";
  $("stream-end").disabled = !recording || s.waiting !== "streaming";
  for (const id of Object.values(STREAM_INPUTS)) $(id).disabled = s.phase !== "recording";
  const where = s.waiting === "streaming" ? stream.trial + ": streaming"
    : s.waiting === "trial" ? (stream.trial + 1) + ": ready to start" : "";
  // with the recorder gone the last state's "streaming" is no longer so (r7 K5)
  setText($("stream-where"), connected ? where : "");
  const frames = stream.frames || [0, 0];
  setText($("stream-frames"), "frames: camera 1 " + frames[0] + ", camera 2 " + frames[1] +
    (stream.offset ? "; clock offset " + stream.offset : ""));
  if (changed("stream-touches", stream.touches)) {
    $("stream-touches").replaceChildren(...(stream.touches || []).map((t) =>
      el("li", "touch " + t.touch + " at (" + t.point.map((v) => num(v)).join(", ") + ") by " + t.how)));
  }
  if (changed("stream-ended", stream.ended)) {
    $("stream-ended").replaceChildren(...(stream.ended || []).map((line) => el("li", line)));
  }
  if (streamRefusal && streamRefusal.at !== stepOf(s)) streamRefusal = null;
  const r = s.refusal || {};
  const theirs = r.seq && ["start", "touch", "end"].includes(r.control) && r.seq > dismissedRefusal;
  const refused = streamRefusal ? streamRefusal.message : theirs ? r.message : "";
  show($("stream-refusal"), !!refused);
  setText($("stream-refusal"), refused);
}

async function streamAction(action) {
  const body = {action};
  if (action === "touch") {
    for (const [key, id] of Object.entries(STREAM_INPUTS)) body[key] = $(id).value;
  }
  sent = {what: action, words: action === "touch" ? "touch sent" : action + " sent"};
  streamRefusal = null;
  const answer = await post("/api/stream", body);
  for (const [key, id] of Object.entries(STREAM_INPUTS)) {
    $(id).classList.toggle("invalid", !answer.ok && !!(answer.errors || {})[key]);
  }
  if (!answer.ok) {
    streamRefusal = {message: answer.error || "refused", at: stepOf(state)};
    show($("stream-refusal"), true);
    setText($("stream-refusal"), streamRefusal.message);
  }
}

$("stream-start").addEventListener("click", () => act(() => streamAction("start"), "start"));
$("stream-end").addEventListener("click", () => act(() => streamAction("end"), "end"));
$("stream-form").addEventListener("submit", (event) => {
  event.preventDefault();
  act(() => streamAction("touch"), "touch");
});
