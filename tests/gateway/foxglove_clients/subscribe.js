// Connects to the live view with @foxglove/ws-protocol's FoxgloveClient, as a viewer written from its
// documentation does, subscribes to the topics named on the command line and prints, for each, its first
// message as a JSON line (topic, schema name, log time, payload in base64); then closes and exits.
//   node subscribe.js ws://127.0.0.1:8765/?token=... /kemar/currentState /world/kemar_camera_left ...
"use strict";
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { WebSocket } = require("ws");

const [url, ...topics] = process.argv.slice(2);
const socket = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws: socket });
const byTopic = new Map();
const bySubscription = new Map();
const done = new Set();
const fail = (why) => {
  console.error(why);
  process.exit(1);
};
setTimeout(() => fail(`timeout: got ${[...done].join(", ")}`), 60_000).unref();

client.on("error", (error) => fail(`error: ${error && error.message}`));
client.on("close", () => done.size < topics.length && fail("closed before every topic came"));
client.on("serverInfo", (info) => console.log(JSON.stringify({ serverInfo: info.name, protocol: socket.protocol })));
client.on("advertise", (channels) => {
  for (const channel of channels) {
    if (topics.includes(channel.topic) && !byTopic.has(channel.topic)) {
      byTopic.set(channel.topic, channel);
      bySubscription.set(client.subscribe(channel.id), channel);
    }
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const channel = bySubscription.get(subscriptionId);
  if (channel === undefined || done.has(channel.topic)) return;
  done.add(channel.topic);
  const payload = Buffer.from(data.buffer, data.byteOffset, data.byteLength);
  console.log(JSON.stringify({ topic: channel.topic, schemaName: channel.schemaName, encoding: channel.encoding,
                               logTime: timestamp.toString(), data: payload.toString("base64") }));
  if (done.size === topics.length) {
    client.close(); // Node then exits, once stdout is written out (process.exit could cut a pipe's last lines)
  }
});
