// The camera panel: the live image (its last frame kept when the recorder stops), the
// capture's progress and its frames table, frame by frame, with the pose's average.
"use strict";

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
  else if (s.phase === "recording" && connected && !live.naturalWidth) {
    // a pair shows camera 1's frames as a trial records them, none before (r7 K9)
    note = s.stream && s.waiting === "trial" ? "camera 1's view shows once a trial's stream starts" :
      "waiting for the camera's first frame...";
  }
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
  const page = s.page;
  const pair = !!s.stream;
  if (changed("frames-head", [page.camera_aside, page.detection_columns, page.objects_header, pair])) {
    // What the method's page says (the server's): the aside, and the table's columns; a
    // pair's preview is camera 1's frames as recorded, nothing drawn on them (r7 K5).
    setText($("camera-aside"), pair ? "camera 1's frames as recorded" : page.camera_aside);
    const head = $("frames-table").tHead.rows[0];
    for (const th of head.cells) show(th, page.detection_columns || th.cellIndex < 2);
    head.cells[1].textContent = page.objects_header;
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
    el("td", (f.line || "").replace(/^line /, "").replace(/ ([uv])\b/g, "$1"), "image-line"),
  );
  return tr;
}
