// Read MCAP files with @mcap/core, independently of the Python mcap library: as a stream
// and through the summary index, with CRCs checked both ways; count messages per topic;
// validate every JSON message against the JSON schema its channel declares.
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

async function validate(path) {
  const report = { stream: {}, indexed: {}, json_validated: 0, errors: [] };
  // 1. As a stream, every record in file order, chunk and data-section CRCs checked.
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(await readFile(path));
  const schemas = new Map();
  const channels = new Map();
  const validators = new Map();
  const ajv = new Ajv2020({ strict: false, allErrors: true });
  let record;
  while ((record = stream.nextRecord())) {
    if (record.type === "Schema") schemas.set(record.id, record);
    else if (record.type === "Channel") channels.set(record.id, record);
    else if (record.type === "Message") {
      const channel = channels.get(record.channelId);
      countInto(report.stream, channel.topic);
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
      const message = JSON.parse(decoder.decode(record.data));
      if (check(message)) report.json_validated += 1;
      else report.errors.push(`${channel.topic}: ${ajv.errorsText(check.errors)}`);
    }
  }
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
