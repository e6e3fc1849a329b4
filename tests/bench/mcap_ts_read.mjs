// The check of docs/recording.md "Opening a run in a viewer" (not a test; needs Node):
//   npm install @mcap/core protobufjs fzstd && node tests/bench/mcap_ts_read.mjs LOG.mcap
// Read a run's MCAP the way Foxglove does: @mcap/core's indexed reader (chunk + message
// indexes), protobuf channels through protobufjs from the FileDescriptorSet in the file.
import { McapIndexedReader } from "@mcap/core";
import { open } from "node:fs/promises";
import protobuf from "protobufjs";
import descriptor from "protobufjs/ext/descriptor/index.js";
import { decompress } from "fzstd";

const path = process.argv[2];
const fh = await open(path, "r");
const readable = {
  size: async () => BigInt((await fh.stat()).size),
  read: async (offset, length) => {
    const buf = new Uint8Array(Number(length));
    await fh.read(buf, 0, Number(length), Number(offset));
    return buf;
  },
};
const reader = await McapIndexedReader.Initialize({
  readable,
  decompressHandlers: { zstd: (data, size) => decompress(data, new Uint8Array(Number(size))) },
});
const decoders = new Map();
for (const [id, ch] of reader.channelsById) {
  const schema = reader.schemasById.get(ch.schemaId);
  if (ch.messageEncoding === "protobuf") {
    const fds = descriptor.FileDescriptorSet.decode(schema.data);
    const root = protobuf.Root.fromDescriptor(fds);
    const type = root.lookupType(schema.name);
    decoders.set(id, (d) => type.toObject(type.decode(d), { longs: Number, bytes: Array, defaults: false }));
  } else {
    decoders.set(id, (d) => JSON.parse(new TextDecoder().decode(d)));
  }
}
const counts = {};
const first = {};
let last = -1n, ordered = true;
for await (const msg of reader.readMessages()) {
  const ch = reader.channelsById.get(msg.channelId);
  const obj = decoders.get(msg.channelId)(msg.data);
  counts[ch.topic] = (counts[ch.topic] ?? 0) + 1;
  if (!(ch.topic in first) && counts[ch.topic] === 100) first[ch.topic] = obj;
  if (msg.logTime < last) ordered = false;
  last = msg.logTime;
}
console.log("log-time ordered:", ordered);
console.log(JSON.stringify(counts));
for (const t of ["/sim/truth", "/hil/adc/conversion", "/hil/imu/sample", "/hil/timing/tick", "/tf"]) {
  const o = first[t];
  if (o && o.data) o.data = `<${o.data.length} bytes>`;
  console.log(t, JSON.stringify(o).slice(0, 400));
}
const w = first["/hil/wire/imu/tx"];
console.log("/hil/wire/imu/tx", JSON.stringify({ ...w, data: `<${w.data.length} bytes>`, chunk_dt_host_ns: undefined }).slice(0, 300));
