// An independent Foxglove WebSocket client (@foxglove/ws-protocol, the client Lichtblick uses):
// connects with the subprotocol given, subscribes to the topics given, decodes each message's
// CDR with @foxglove/rosmsg2-serialization from the channel's ros2msg schema, and prints one
// JSON line per message (a JSON channel's as it is) until it has `count` messages on every
// topic (8 x count on the frames topic), then disconnects.
// usage: node client.cjs URL SUBPROTOCOL COUNT TOPIC...
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");
const { parse } = require("@foxglove/rosmsg");
const WebSocket = require("ws");

const [url, subprotocol, countText, ...topics] = process.argv.slice(2);
const count = Number(countText);
const FRAMES = "/live/frames"; // the sighting chain's transforms: 8 x count messages (4 sources)
const ws = new WebSocket(url, [subprotocol]);
const client = new FoxgloveClient({ ws });
const subs = new Map(); // subscription id -> {topic, reader}
const got = new Map(topics.map((t) => [t, 0]));

ws.on("unexpected-response", (_req, res) => {
  console.error(`handshake refused: HTTP ${res.statusCode}`);
  process.exit(3);
});
client.on("open", () => console.log(JSON.stringify({ open: ws.protocol })));
client.on("error", (err) => { console.error(String(err)); process.exit(4); });
client.on("advertise", (channels) => {
  for (const ch of channels) {
    if (!got.has(ch.topic)) continue;
    let reader;
    if (ch.encoding === "cdr" && ch.schemaEncoding === "ros2msg") {
      reader = new MessageReader(parse(ch.schema, { ros2: true }));
    } else if (ch.encoding === "json" && ch.schemaEncoding === "jsonschema") {
      reader = { readMessage: (bytes) => JSON.parse(Buffer.from(bytes).toString("utf8")) };
    } else {
      console.error(`unexpected encodings on ${ch.topic}: ${ch.encoding}/${ch.schemaEncoding}`);
      process.exit(5);
    }
    subs.set(client.subscribe(ch.id), { topic: ch.topic, schemaName: ch.schemaName, reader });
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const sub = subs.get(subscriptionId);
  if (!sub || got.get(sub.topic) >= (sub.topic === FRAMES ? 8 * count : count)) return;
  const msg = sub.reader.readMessage(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
  got.set(sub.topic, got.get(sub.topic) + 1);
  console.log(JSON.stringify({ topic: sub.topic, schema: sub.schemaName, log_time: String(timestamp), msg },
    (_k, v) => (typeof v === "bigint" ? String(v) : v)));
  if ([...got.entries()].every(([t, n]) => n >= (t === FRAMES ? 8 * count : count))) {
    client.close();
    process.exit(0);
  }
});
