// Read MCAP files with @mcap/core, independently of the Python mcap library: as a stream
// and through the summary index, with CRCs checked both ways; count messages per topic;
// validate every JSON message against the JSON schema its channel declares; and, from
// docs/session-format.md alone, rebuild the captures a format 1.1 session is measured from.
// Usage: node validate.mjs FILE...   Prints one JSON object: {file: report}.
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";
import { loadDecompressHandlers } from "@mcap/support";
import Ajv2020 from "ajv/dist/2020.js";
import { open, readFile } from "node:fs/promises";

const decompressHandlers = await loadDecompressHandlers();
const decoder = new TextDecoder();

function countInto(counts, topic) {
  counts[topic] = (counts[topic] ?? 0) + 1;
}

// Format 1.1 (docs/session-format.md, "Which captures are measured"): a capture is used
// when it has a pose entry, a complete window holding frames, and the last decision
// naming it is "accept"; per trial and pose the latest such capture. Returns sorted
// [trial, pose, capture, frames on the image topic inside the window].
function acceptedCaptures(state) {
  const best = new Map();
  for (const [capture, pose] of state.poses) {
    const window = state.windows.get(capture);
    const decision = state.decisions.get(capture);
    if (!window || window.status !== "complete" || window.n_frames === 0) continue;
    if (!decision || decision.decision !== "accept") continue;
    const times = state.frames.get(window.camera) ?? [];
    const frames = times.filter((t) => t >= window.start_ns && t <= window.end_ns);
    const key = `${pose.trial}/${pose.pose}`;
    const earlier = best.get(key);
    if (!earlier || earlier[2] < capture) best.set(key, [pose.trial, pose.pose, capture, frames.length]);
  }
  return [...best.values()].sort((a, b) => a[0] - b[0] || a[1] - b[1]);
}

// Nanosecond times exceed 2^53: read them from the JSON text as BigInt, not as numbers.
function bigField(text, name) {
  return BigInt(text.match(new RegExp(`"${name}"\\s*:\\s*(\\d+)`))[1]);
}

function track(state, topic, message, text) {
  if (topic === "/twopose/pose" && message.capture !== undefined) state.poses.set(message.capture, message);
  else if (topic === "/twopose/capture" && message.capture !== undefined) {
    state.windows.set(message.capture, {
      ...message,
      start_ns: bigField(text, "start_ns"),
      end_ns: bigField(text, "end_ns"),
    });
  }
  else if (topic === "/twopose/decision") state.decisions.set(message.capture, message);
}

async function validate(path) {
  const report = { stream: {}, indexed: {}, json_validated: 0, errors: [] };
  // 1. As a stream, every record in file order, chunk and data-section CRCs checked.
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(await readFile(path));
  const schemas = new Map();
  const channels = new Map();
  const validators = new Map();
  const ajv = new Ajv2020({ strict: false, allErrors: true });
  const state = { poses: new Map(), windows: new Map(), decisions: new Map(), frames: new Map() };
  let record;
  while ((record = stream.nextRecord())) {
    if (record.type === "Schema") schemas.set(record.id, record);
    else if (record.type === "Channel") channels.set(record.id, record);
    else if (record.type === "Message") {
      const channel = channels.get(record.channelId);
      countInto(report.stream, channel.topic);
      const image = channel.topic.match(/^\/twopose\/camera\/([^/]+)\/image$/);
      if (image) (state.frames.get(image[1]) ?? state.frames.set(image[1], []).get(image[1])).push(record.logTime);
      if (channel.messageEncoding !== "json") continue;
      const schema = schemas.get(channel.schemaId);
      if (!schema || schema.encoding !== "jsonschema") {
        report.errors.push(`${channel.topic}: json message without a jsonschema schema`);
        continue;
      }
      if (!validators.has(schema.id)) {
        const parsed = JSON.parse(decoder.decode(schema.data));
        delete parsed.$id; // several files may declare the same ids; one ajv per file is enough
        validators.set(schema.id, ajv.compile(parsed));
      }
      const check = validators.get(schema.id);
      const text = decoder.decode(record.data);
      const message = JSON.parse(text);
      if (check(message)) report.json_validated += 1;
      else report.errors.push(`${channel.topic}: ${ajv.errorsText(check.errors)}`);
      track(state, channel.topic, message, text);
    }
  }
  report.accepted = acceptedCaptures(state);
  if (!stream.done()) report.errors.push(`stream ended with ${stream.bytesRemaining()} bytes unread`);
  // 2. Through the index (summary, chunk indexes, message indexes), CRCs checked.
  const handle = await open(path, "r");
  try {
    const reader = await McapIndexedReader.Initialize({
      readable: new FileHandleReadable(handle),
      decompressHandlers,
    });
    for await (const message of reader.readMessages({ validateCrcs: true })) {
      countInto(report.indexed, reader.channelsById.get(message.channelId).topic);
    }
    report.statistics_message_count = Number(reader.statistics?.messageCount ?? -1);
  } finally {
    await handle.close();
  }
  return report;
}

const out = {};
for (const path of process.argv.slice(2)) {
  try {
    out[path] = await validate(path);
  } catch (err) {
    out[path] = { errors: [`${err.name}: ${err.message}`] };
  }
}
process.stdout.write(JSON.stringify(out));
