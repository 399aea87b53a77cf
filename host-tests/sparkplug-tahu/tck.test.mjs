// The gateway's Sparkplug B as a plant's host reads it: every message
// decoded by Eclipse Tahu's JavaScript library (npm `sparkplug-payload`,
// which Node-RED's Sparkplug nodes use; pinned by package-lock.json), and
// checked against the Sparkplug 3.0 TCK assertions for an edge node that
// apply to the gateway (each test is named by its assertion's id).
//
// One scenario, on 127.0.0.1 at free ports: Debian's Mosquitto; the
// subscriber `mosquitto_sub` (topic, delivered QoS and payload of every
// message under spBv1.0/#, QoS 1); hans-sim (ready, StandBy); the
// `hans-gateway` binary with `--mqtt`. Then: births; two commands from
// Modbus (mbpoll: a relative joint move, Done; an unknown code, Error);
// a rebirth request and a DCMD write, both encoded by Tahu's encoder; the
// simulator stopped (DDEATH) and started again (DBIRTH); the broker
// restarted (a new session: the next bdSeq); the gateway killed (SIGKILL:
// the Will); a second gateway stopped with SIGTERM (in order, exit 0; the
// Will again: it closes its connection without DISCONNECT).
// Every wait is for a message or a condition, bounded (WAIT); every
// process started here is stopped by its pid.
//
// Run by host-tests/sparkplug-tahu/run.sh (which installs the library into
// target/sparkplug-tahu and builds the binaries): environment TAHU_DIR,
// HANS_GATEWAY, HANS_SIM.

import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { spawn, spawnSync } from "node:child_process";
import { createRequire } from "node:module";
import fs from "node:fs";
import net from "node:net";
import os from "node:os";
import path from "node:path";

const WAIT = 20_000;
const env = (name) => {
  const v = process.env[name];
  if (!v) throw new Error(`${name} is not set (run host-tests/sparkplug-tahu/run.sh)`);
  return v;
};
const require = createRequire(path.join(env("TAHU_DIR"), "package.json"));
const tahu = require("sparkplug-payload").get("spBv1.0");
// The library's own protobuf layer, for what its decoder leaves out of
// its result: whether the metric said is_null.
const Proto = require("sparkplug-payload/lib/sparkplugPayloadProto.js").org.eclipse.tahu.protobuf.Payload;

const GROUP = "cells";
const work = fs.mkdtempSync(path.join(os.tmpdir(), "sparkplug-tahu-"));
const started = [];

function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.on("error", reject);
    s.listen(0, "127.0.0.1", () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });
}

function start(cmd, args, name) {
  // In the work directory: the gateway writes its setup-code file there.
  const child = spawn(cmd, args, { cwd: work, stdio: ["ignore", "pipe", "pipe"] });
  child.name = name;
  child.out = "";
  child.stdout.on("data", (d) => (child.out += d));
  child.stderr.on("data", (d) => (child.out += d));
  child.ended = new Promise((resolve) => child.on("exit", (code, signal) => resolve({ code, signal })));
  started.push(child);
  return child;
}

async function stop(child, signal = "SIGTERM") {
  if (child.exitCode === null && child.signalCode === null) child.kill(signal);
  return child.ended;
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function until(what, cond, limit = WAIT) {
  const end = Date.now() + limit;
  for (;;) {
    const v = await cond();
    if (v) return v;
    if (Date.now() > end) throw new Error(`${what}: not within ${limit} ms`);
    await sleep(50);
  }
}

const num = (v) => (v !== null && typeof v === "object" && "low" in v ? Number(v.toString()) : v);

// --- the broker and the subscriber

let brokerPort;
let broker;
async function startBroker() {
  const conf = path.join(work, "mosquitto.conf");
  fs.writeFileSync(conf, `listener ${brokerPort} 127.0.0.1\nallow_anonymous true\npersistence false\n`);
  const bin = fs.existsSync("/usr/sbin/mosquitto") ? "/usr/sbin/mosquitto" : "mosquitto";
  broker = start(bin, ["-c", conf], "mosquitto");
  await until("the broker listens", () =>
    new Promise((resolve) => {
      const s = net.connect(brokerPort, "127.0.0.1", () => (s.destroy(), resolve(true)));
      s.on("error", () => resolve(false));
    }));
}

/** Every message seen, decoded: topic, type, edge, device, qos, the raw
 * bytes, Tahu's decoding and the raw is_null flags. */
const msgs = [];
let sub;
let lineBuf = "";
function startSubscriber() {
  sub = start("mosquitto_sub", ["-h", "127.0.0.1", "-p", String(brokerPort), "-q", "1", "-t", "spBv1.0/#",
    "-t", "probe/#", "-F", "%t %q %x"], "mosquitto_sub");
  sub.stdout.on("data", (d) => {
    lineBuf += d;
    let i;
    while ((i = lineBuf.indexOf("\n")) >= 0) {
      const line = lineBuf.slice(0, i);
      lineBuf = lineBuf.slice(i + 1);
      const [topic, qos, hex = ""] = line.split(" ");
      const bytes = Buffer.from(hex, "hex");
      const m = { topic, qos: Number(qos), bytes, at: Date.now() };
      const parts = topic.split("/");
      if (parts[0] === "spBv1.0") {
        [, m.group, m.type, m.edge, m.device] = parts;
        try {
          m.p = tahu.decodePayload(bytes);
          m.raw = Proto.decode(bytes);
        } catch (e) {
          m.error = String(e);
        }
      }
      msgs.push(m);
    }
  });
}

/** Subscribed: a probe published now comes back. */
async function probe() {
  const id = `probe/${Date.now()}-${Math.random()}`;
  return until("the subscriber sees a probe", () => {
    spawnSync("mosquitto_pub", ["-h", "127.0.0.1", "-p", String(brokerPort), "-t", id, "-m", "x"]);
    return msgs.some((m) => m.topic === id);
  });
}

function next(what, pred, from = 0) {
  return until(what, () => msgs.slice(from).find(pred));
}

const metric = (m, name) => m.p.metrics.find((x) => x.name === name);
const value = (m, name) => num(metric(m, name)?.value);

function publish(topic, payload) {
  const f = path.join(work, "payload.bin");
  fs.writeFileSync(f, Buffer.from(tahu.encodePayload(payload)));
  const r = spawnSync("mosquitto_pub", ["-h", "127.0.0.1", "-p", String(brokerPort), "-q", "1", "-t", topic, "-f", f]);
  assert.equal(r.status, 0, `mosquitto_pub ${topic}: ${r.stderr}`);
}

// --- the robot, the gateway and the PLC

let simPort;
let sim;
function startSim() {
  sim = start(env("HANS_SIM"), ["--host", "127.0.0.1", "--command-port", String(simPort), "--datasheet-ports", "",
    "--ready"], "hans-sim");
}

let modbusPort;
function startGateway() {
  return start(env("HANS_GATEWAY"), ["--modbus-listen", `127.0.0.1:${modbusPort}`, "--robot", `127.0.0.1:${simPort}`,
    "--mqtt", `127.0.0.1:${brokerPort}`], "hans-gateway");
}

/** `mbpoll` on the gateway: options, then the values to write (none: a
 * read); its output. */
function mbpoll(opts, ...values) {
  const args = ["-m", "tcp", "-p", String(modbusPort), "-0", ...opts.split(" "), "-1", "127.0.0.1", ...values.map(String)];
  const r = spawnSync("mbpoll", args, { encoding: "utf8", timeout: 10_000 });
  assert.equal(r.status, 0, `mbpoll ${args.join(" ")}: ${r.stdout}${r.stderr}`);
  return r.stdout;
}

/** Fires command `code` with sequence `seq` on channel 0 (parameters as
 * floats at 204), waits until it ends; its CH0_STATUS. */
async function command(code, seq, params = []) {
  mbpoll("-r 200", 0, code, seq);
  if (params.length) mbpoll("-t 4:float -B -r 204", ...params);
  mbpoll("-r 200", 1);
  const status = await until(`command ${code} ends`, () => {
    const s = Number(/\[260\]:\s+(\d+)/.exec(mbpoll("-r 260"))?.[1]);
    return (s & 0b1110) !== 0 ? s : 0;
  });
  mbpoll("-r 200", 0);
  return status;
}

// --- the scenario

const sessions = []; // per gateway session: { nbirth, will }
let gw1;
let gw2;
let gw1Status;
let gw2Status;
let rebirthAt;
let dcmdAt;
let simStopAt;
let brokerRestartAt;
let killAt;
let firstData;

before(async () => {
  [brokerPort, simPort, modbusPort] = await Promise.all([freePort(), freePort(), freePort()]);
  await startBroker();
  startSubscriber();
  await probe();
  startSim();
  gw1 = startGateway();
  const nb = await next("the first NBIRTH", (m) => m.type === "NBIRTH");
  await next("the DBIRTH", (m) => m.type === "DBIRTH" && m.edge === nb.edge);
  // Settled: the robot's state known (DDATA after the link's status polls).
  await until("FSM known", () => msgs.some((m) => ["DBIRTH", "DDATA"].includes(m.type) && value(m, "FSM/Code") === 33));
  firstData = msgs.length;
  // Commands from Modbus: J1 +10 degrees (Done), an unknown code (Error).
  assert.equal(await command(13, 1, [0, 10]), 2, "the relative joint move is Done");
  assert.equal(await command(99, 2), 4, "code 99 ends in Error");
  await next("the error's event", (m) => m.type === "NDATA" && value(m, "Last Command/Code") === 99, firstData);
  // A host asks for a rebirth (Tahu's encoder), then writes a robot metric.
  rebirthAt = msgs.length;
  publish(`spBv1.0/${GROUP}/NCMD/${nb.edge}`, { timestamp: Date.now(),
    metrics: [{ name: "Node Control/Rebirth", type: "Boolean", value: true }] });
  await next("the rebirth's DBIRTH", (m) => m.type === "DBIRTH", rebirthAt);
  dcmdAt = msgs.length;
  publish(`spBv1.0/${GROUP}/DCMD/${nb.edge}/robot`, { timestamp: Date.now(),
    metrics: [{ name: "Flags/Moving", type: "Boolean", value: true }] });
  await next("the refusal counted", (m) => m.type === "NDATA" && value(m, "MQTT/Writes Refused") === 1, dcmdAt);
  // The robot link drops, and comes back.
  simStopAt = msgs.length;
  await stop(sim, "SIGKILL");
  await next("the DDEATH", (m) => m.type === "DDEATH", simStopAt);
  startSim();
  await next("the DBIRTH after the link is back", (m) => m.type === "DBIRTH", simStopAt);
  // The broker restarts: a new MQTT session, the next bdSeq.
  brokerRestartAt = msgs.length;
  await stop(broker, "SIGTERM");
  await stop(sub, "SIGTERM");
  await startBroker();
  startSubscriber();
  await probe();
  await next("the NBIRTH of the next session", (m) => m.type === "NBIRTH", brokerRestartAt);
  await next("its DBIRTH", (m) => m.type === "DBIRTH", brokerRestartAt);
  // Killed: the broker publishes the Will.
  killAt = msgs.length;
  gw1Status = await stop(gw1, "SIGKILL");
  await next("the NDEATH (the Will, after SIGKILL)", (m) => m.type === "NDEATH", killAt);
  // A second gateway, stopped as systemd stops it.
  const before2 = msgs.length;
  gw2 = startGateway();
  await next("the second gateway's NBIRTH", (m) => m.type === "NBIRTH", before2);
  const term = msgs.length;
  gw2Status = await stop(gw2, "SIGTERM");
  await next("the NDEATH after SIGTERM", (m) => m.type === "NDEATH", term);
});

after(async () => {
  for (const c of started.reverse()) await stop(c, "SIGKILL");
  fs.rmSync(work, { recursive: true, force: true });
});

const sp = () => msgs.filter((m) => m.group !== undefined);
const of = (type) => sp().filter((m) => m.type === type);
const fromTheNode = (list) => list.filter((m) => m.type !== "NCMD" && m.type !== "DCMD");

// --- every message

test("every message decodes with Tahu's decoder (tck-id-message-flow-edge-node-birth-publish-nbirth-payload, "
  + "-dbirth-payload, -will-message-payload)", () => {
  assert.ok(sp().length > 10, `${sp().length} messages`);
  for (const m of sp()) assert.equal(m.error, undefined, `${m.topic}: ${m.error}`);
});

test("every value the gateway knows is read by Tahu's decoder: null only where the metric says is_null "
  + "(tck-id-operational-behavior-data-publish-nbirth-values, -dbirth-values)", () => {
  let n = 0;
  for (const m of fromTheNode(sp())) {
    m.p.metrics.forEach((x, i) => {
      const isNull = m.raw.metrics[i].isNull === true;
      const missing = x.value === null || x.value === undefined;
      assert.equal(missing, isNull, `${m.topic} ${x.name} (${x.type}): Tahu reads ${x.value}, is_null ${isNull}`);
      n += 1;
    });
  }
  assert.ok(n > 200, `${n} metrics`);
});

test("the integer metrics that were UInt32 read as numbers in Tahu's decoder", () => {
  // A birth after the commands (the rebirth's): its last command is known.
  const nb = of("NBIRTH").filter((m) => value(m, "Last Command/Code") === 99).at(-1);
  assert.ok(nb, "an NBIRTH after the commands");
  for (const name of ["Gateway/Uptime", "MQTT/Writes Refused", "Last Command/Duration"]) {
    const x = metric(nb, name);
    assert.equal(typeof x.value, "number", `${name}: ${x.value}`);
    assert.equal(x.type, "Int32", name);
  }
  const event = of("NDATA").find((m) => value(m, "Last Command/Code") === 13);
  assert.ok(value(event, "Last Command/Duration") > 0, "the move took time");
  assert.equal(value(event, "Last Command/Result"), "done");
  const err = of("NDATA").find((m) => value(m, "Last Command/Code") === 99);
  assert.equal(value(err, "Last Command/Error Id"), 39501);
  assert.equal(value(err, "Last Command/Error Source"), 3);
});

test("tck-id-payloads-name-requirement: every metric has its name (no aliases)", () => {
  for (const m of fromTheNode(sp())) for (const x of m.p.metrics) assert.ok(x.name, m.topic);
});

test("tck-id-payloads-name-birth-data-requirement: every metric of births and data has a timestamp", () => {
  for (const m of sp().filter((m) => /BIRTH|DATA/.test(m.type) && !/CMD/.test(m.type))) {
    for (const x of m.p.metrics) assert.notEqual(x.timestamp, undefined, `${m.topic} ${x.name}`);
  }
});

test("tck-id-payloads-metric-datatype-value-type, tck-id-payloads-metric-datatype-value, "
  + "tck-id-payloads-metric-datatype-req: births give every metric a valid datatype", () => {
  for (const m of [...of("NBIRTH"), ...of("DBIRTH")]) {
    m.raw.metrics.forEach((x, i) => {
      assert.ok(Number.isInteger(x.datatype) && x.datatype >= 1 && x.datatype <= 34, `${x.name}: ${x.datatype}`);
      assert.ok(m.p.metrics[i].type, `${x.name}: Tahu knows the type`);
    });
  }
});

test("tck-id-payloads-sequence-num-always-included: seq in every message but NDEATH, 0-255", () => {
  for (const m of fromTheNode(sp())) {
    if (m.type === "NDEATH") continue;
    const s = num(m.p.seq);
    assert.ok(Number.isInteger(s) && s >= 0 && s <= 255, `${m.topic}: seq ${s}`);
  }
});

test("tck-id-payloads-sequence-num-incrementing (and -ndata-seq-inc, -ddata-seq-inc, -dbirth-seq-inc, "
  + "-ddeath-seq-inc, tck-id-topics-ddeath-seq-num): one more per message after the NBIRTH, per session", () => {
  let last = null;
  let checked = 0;
  for (const m of fromTheNode(sp())) {
    if (m.type === "NDEATH") continue;
    const s = num(m.p.seq);
    if (m.type === "NBIRTH") {
      last = s;
      continue;
    }
    if (last !== null) {
      assert.equal(s, (last + 1) % 256, `${m.type} after seq ${last}`);
      checked += 1;
    }
    last = s;
  }
  assert.ok(checked > 5, `${checked}`);
});

// --- NBIRTH

test("tck-id-message-flow-edge-node-birth-publish-nbirth-topic, tck-id-topics-nbirth-topic", () => {
  for (const m of of("NBIRTH")) assert.match(m.topic, new RegExp(`^spBv1\\.0/${GROUP}/NBIRTH/[^/]+$`));
});

test("tck-id-message-flow-edge-node-birth-publish-nbirth-qos, tck-id-payloads-nbirth-qos (QoS 0)", () => {
  for (const m of of("NBIRTH")) assert.equal(m.qos, 0);
});

test("tck-id-topics-nbirth-seq-num, tck-id-payloads-nbirth-seq, tck-id-payloads-sequence-num-req-nbirth, "
  + "tck-id-message-flow-edge-node-birth-publish-nbirth-payload-seq: seq 0", () => {
  assert.ok(of("NBIRTH").length >= 4);
  for (const m of of("NBIRTH")) assert.equal(num(m.p.seq), 0);
});

test("tck-id-payloads-nbirth-timestamp, tck-id-topics-nbirth-timestamp (and DBIRTH, NDATA, DDATA, DDEATH: "
  + "tck-id-payloads-dbirth-timestamp, -ndata-timestamp, -ddata-timestamp, -ddeath-timestamp)", () => {
  for (const m of fromTheNode(sp())) {
    if (m.type === "NDEATH") continue;
    const t = num(m.p.timestamp);
    assert.ok(t > 1.6e12 && Math.abs(t - m.at) < 60_000, `${m.topic}: timestamp ${t}`);
  }
});

test("tck-id-payloads-nbirth-bdseq, tck-id-topics-nbirth-bdseq-included, "
  + "tck-id-message-flow-edge-node-birth-publish-nbirth-payload-bdSeq: bdSeq, INT64", () => {
  for (const m of of("NBIRTH")) {
    const x = metric(m, "bdSeq");
    assert.equal(x.type, "Int64");
    assert.ok(Number.isInteger(num(x.value)));
  }
});

test("tck-id-payloads-nbirth-rebirth-req, tck-id-topics-nbirth-rebirth-metric: Node Control/Rebirth false", () => {
  for (const m of of("NBIRTH")) {
    const x = metric(m, "Node Control/Rebirth");
    assert.equal(x.type, "Boolean");
    assert.equal(x.value, false);
  }
});

test("tck-id-topics-nbirth-metrics, tck-id-topics-dbirth-metrics, tck-id-topics-nbirth-metric-reqs, "
  + "tck-id-topics-dbirth-metric-reqs: births name every metric data messages carry, with its value", () => {
  const born = new Set();
  for (const m of fromTheNode(sp())) {
    if (m.type === "NBIRTH" || m.type === "DBIRTH") {
      for (const x of m.p.metrics) born.add(`${m.device ?? ""}/${x.name}`);
      // The gateway's births after the robot is known: every such value.
      m.p.metrics.forEach((x, i) => assert.ok(x.value !== undefined || m.raw.metrics[i].isNull, x.name));
    }
    if (m.type === "NDATA" || m.type === "DDATA") {
      for (const x of m.p.metrics) assert.ok(born.has(`${m.device ?? ""}/${x.name}`), `${m.topic}: ${x.name} unborn`);
    }
  }
  // Values the gateway knows once the robot is connected, read by Tahu.
  const nb = of("NBIRTH").find((m) => msgs.indexOf(m) >= rebirthAt);
  const db = of("DBIRTH").find((m) => msgs.indexOf(m) >= rebirthAt);
  const known = {
    nb: ["bdSeq", "Node Control/Rebirth", "Gateway/Version", "Gateway/Map Version", "Gateway/Uptime", "Link/State",
      "Link/Connects", "Link/Losses", "Link/Protocol", "Watchdog/Armed", "Watchdog/Tripped", "Watchdog/Trips",
      "Modbus/Sessions", "Modbus/Refused", "Modbus/Writes Refused", "Web/Refused", "MQTT/Writes Refused",
      "Queue/Used", "Last Command/Source", "Last Command/Code", "Last Command/Text", "Last Command/Result",
      "Last Command/Error Id", "Last Command/Error Source", "Last Command/Duration", "Channel 0/Phase",
      "Channel 0/Last Outcome", "Channel 0/Last Error Id", "RAW/Phase", "Trigger 15/Last Error Id"],
    db: ["FSM/Code", "FSM/Name", "Flags/Moving", "Flags/Enabled", "Flags/Powered", "Flags/Emergency Stop",
      "Error/Code", "Error/Axis", "Joints/J1", "Joints/J6", "Pose/X", "Pose/Rz"],
  };
  for (const name of known.nb) assert.notEqual(metric(nb, name)?.value ?? null, null, `NBIRTH ${name}`);
  for (const name of known.db) assert.notEqual(metric(db, name)?.value ?? null, null, `DBIRTH ${name}`);
  assert.equal(value(nb, "Link/State"), "connected");
  assert.equal(value(nb, "Link/Connects"), 1);
  assert.equal(value(nb, "Last Command/Code"), 99, "the last command, in the birth");
  assert.equal(value(db, "FSM/Code"), 33);
  assert.equal(value(db, "FSM/Name"), "StandBy");
  assert.ok(value(db, "Joints/J1") > 9.9, "J1 moved 10 degrees");
  assert.equal(value(nb, "Gateway/Version"), process.env.GATEWAY_VERSION, "the binary's (its package's) version");
});

test("tck-id-payloads-alias-birth-requirement: not applicable, the gateway uses no aliases", () => {
  for (const m of fromTheNode(sp())) for (const x of m.p.metrics) assert.equal(x.alias, undefined);
});

// --- DBIRTH

test("tck-id-message-flow-device-birth-publish-dbirth-topic, tck-id-topics-dbirth-topic, "
  + "tck-id-message-flow-device-birth-publish-dbirth-match-edge-node-topic", () => {
  let lastNode = null;
  for (const m of fromTheNode(sp())) {
    if (m.type === "NBIRTH") lastNode = m;
    if (m.type === "DBIRTH") {
      assert.match(m.topic, new RegExp(`^spBv1\\.0/${GROUP}/DBIRTH/[^/]+/robot$`));
      assert.equal(m.edge, lastNode.edge);
      assert.equal(m.group, lastNode.group);
    }
  }
});

test("tck-id-message-flow-device-birth-publish-dbirth-qos, -dbirth-retained's QoS, "
  + "tck-id-topics-dbirth-mqtt (QoS 0)", () => {
  for (const m of of("DBIRTH")) assert.equal(m.qos, 0);
});

test("tck-id-message-flow-device-birth-publish-nbirth-wait, tck-id-payloads-dbirth-order, "
  + "tck-id-payloads-ndata-order, tck-id-payloads-ddata-order: NBIRTH, then DBIRTH, then data", () => {
  let state = "none";
  for (const m of fromTheNode(sp())) {
    if (m.type === "NBIRTH") state = "nbirth";
    else if (m.type === "DBIRTH") {
      assert.notEqual(state, "none", "a DBIRTH before any NBIRTH");
      state = "born";
    } else if (m.type === "NDATA" || m.type === "DDATA") {
      assert.notEqual(state, "none", `${m.type} before the NBIRTH`);
      if (m.type === "DDATA") assert.equal(state, "born", "DDATA before the DBIRTH");
    } else if (m.type === "DDEATH") state = "nbirth";
  }
});

test("tck-id-message-flow-device-birth-publish-dbirth-payload-seq, tck-id-topics-dbirth-seq: "
  + "the DBIRTH right after the NBIRTH has seq 1", () => {
  const list = fromTheNode(sp());
  list.forEach((m, i) => {
    if (m.type === "NBIRTH" && list[i + 1]?.type === "DBIRTH") assert.equal(num(list[i + 1].p.seq), 1);
  });
});

// --- data

test("tck-id-topics-ndata-topic, tck-id-topics-ddata-topic; tck-id-payloads-ndata-qos, "
  + "tck-id-payloads-ddata-qos, tck-id-topics-ndata-mqtt, tck-id-topics-ddata-mqtt (QoS 0)", () => {
  assert.ok(of("NDATA").length > 0 && of("DDATA").length > 0);
  for (const m of of("NDATA")) {
    assert.match(m.topic, new RegExp(`^spBv1\\.0/${GROUP}/NDATA/[^/]+$`));
    assert.equal(m.qos, 0);
  }
  for (const m of of("DDATA")) {
    assert.match(m.topic, new RegExp(`^spBv1\\.0/${GROUP}/DDATA/[^/]+/robot$`));
    assert.equal(m.qos, 0);
  }
});

test("tck-id-topics-ddata-payload, tck-id-operational-behavior-data-publish-dbirth-change: "
  + "DDATA carries what changed (the joints while J1 turns)", () => {
  const moved = of("DDATA").filter((m) => metric(m, "Joints/J1"));
  assert.ok(moved.length > 0, "J1 published while it turned");
  const j1 = moved.map((m) => value(m, "Joints/J1"));
  for (let i = 1; i < j1.length; i++) assert.notEqual(j1[i], j1[i - 1], "an unchanged value republished");
});

// --- rebirth and commands

test("tck-id-message-flow-edge-node-ncmd-subscribe, tck-id-operational-behavior-data-commands-rebirth-action-2, "
  + "-rebirth-action-3: a rebirth request gives NBIRTH (same bdSeq, seq 0) and DBIRTH", () => {
  // The gateway may publish data it had ready before the broker hands it
  // the NCMD (the request and the subscriber's copy travel apart): data
  // only, then the birth, and the device's birth straight after it.
  const after = fromTheNode(sp()).filter((m) => msgs.indexOf(m) >= rebirthAt);
  const i = after.findIndex((m) => m.type === "NBIRTH");
  assert.ok(i >= 0, "an NBIRTH after the request");
  for (const m of after.slice(0, i)) assert.match(m.type, /^[ND]DATA$/, "only data before the birth");
  const before = of("NBIRTH").filter((m) => msgs.indexOf(m) < rebirthAt).at(-1);
  assert.equal(after[i + 1]?.type, "DBIRTH", "the device's birth right after the node's");
  assert.equal(num(after[i].p.seq), 0);
  assert.equal(value(after[i], "bdSeq"), value(before, "bdSeq"));
});

test("tck-id-message-flow-device-dcmd-subscribe: a DCMD reaches the gateway (and is refused: MQTT never moves "
  + "the robot)", () => {
  const refusal = of("NDATA").find((m) => msgs.indexOf(m) >= dcmdAt && value(m, "MQTT/Writes Refused") === 1);
  assert.ok(refusal);
});

// --- DDEATH

test("tck-id-operational-behavior-device-ddeath, tck-id-topics-ddeath-topic, tck-id-topics-ddeath-mqtt, "
  + "tck-id-payloads-ddeath-seq, tck-id-payloads-ddeath-seq-number", () => {
  const d = of("DDEATH").find((m) => msgs.indexOf(m) >= simStopAt);
  assert.ok(d, "a DDEATH when the robot link dropped");
  assert.match(d.topic, new RegExp(`^spBv1\\.0/${GROUP}/DDEATH/[^/]+/robot$`));
  assert.equal(d.qos, 0);
  assert.ok(Number.isInteger(num(d.p.seq)));
});

// --- bdSeq and the Will

test("tck-id-topics-nbirth-bdseq-increment: the next MQTT session's bdSeq is one more", () => {
  const first = of("NBIRTH").filter((m) => msgs.indexOf(m) < brokerRestartAt).at(-1);
  const second = of("NBIRTH").find((m) => msgs.indexOf(m) >= brokerRestartAt);
  assert.equal(value(second, "bdSeq"), (value(first, "bdSeq") + 1) % 256);
  assert.equal(value(of("NBIRTH")[0], "bdSeq"), 0, "the first session's is 0");
});

test("tck-id-message-flow-edge-node-birth-publish-will-message, tck-id-payloads-ndeath-will-message, "
  + "-will-message-topic, -will-message-payload-bdSeq, tck-id-payloads-ndeath-bdseq, "
  + "tck-id-topics-nbirth-bdseq-matching, tck-id-payloads-nbirth-bdseq-repeat: killed, the Will is the NDEATH "
  + "with the session's bdSeq, INT64", () => {
  assert.equal(gw1Status.signal, "SIGKILL");
  const death = of("NDEATH").find((m) => msgs.indexOf(m) >= killAt);
  const birth = of("NBIRTH").filter((m) => msgs.indexOf(m) < killAt).at(-1);
  assert.equal(death.topic, `spBv1.0/${GROUP}/NDEATH/${birth.edge}`);
  assert.equal(metric(death, "bdSeq").type, "Int64");
  assert.equal(value(death, "bdSeq"), value(birth, "bdSeq"));
});

test("tck-id-message-flow-edge-node-birth-publish-will-message-qos, tck-id-payloads-ndeath-will-message-qos "
  + "(QoS 1, as delivered to a QoS 1 subscriber)", () => {
  for (const m of of("NDEATH")) assert.equal(m.qos, 1);
});

test("tck-id-payloads-ndeath-seq, tck-id-topics-ndeath-seq, tck-id-topics-ndeath-payload: no seq, the bdSeq alone",
  () => {
    for (const m of of("NDEATH")) {
      assert.equal(m.p.seq, undefined);
      assert.deepEqual(m.p.metrics.map((x) => x.name), ["bdSeq"]);
    }
  });

test("SIGTERM (systemd's stop) stops the gateway in order (exit 0) and ends the session with the NDEATH of its bdSeq", () => {
  assert.deepEqual(gw2Status, { code: 0, signal: null });
  const birth = of("NBIRTH").at(-1);
  const death = of("NDEATH").at(-1);
  assert.ok(msgs.indexOf(death) > msgs.indexOf(birth));
  assert.equal(value(death, "bdSeq"), value(birth, "bdSeq"));
});

test("tck-id-message-flow-edge-node-birth-publish-will-message-will-retained, -nbirth-retained, "
  + "-dbirth-retained, tck-id-payloads-ndata-retain, -ddata-retain: nothing is retained", async () => {
  // A subscriber that comes later gets retained messages first, before a
  // probe published after it subscribed.
  const late = spawn("mosquitto_sub", ["-h", "127.0.0.1", "-p", String(brokerPort), "-t", "spBv1.0/#", "-t",
    "late/#", "-F", "%t", "-q", "1"]);
  started.push(late);
  late.ended = new Promise((r) => late.on("exit", r));
  let out = "";
  late.stdout.on("data", (d) => (out += d));
  await until("the late subscriber sees its probe", () => {
    spawnSync("mosquitto_pub", ["-h", "127.0.0.1", "-p", String(brokerPort), "-t", "late/probe", "-m", "x"]);
    return out.includes("late/probe");
  });
  late.kill("SIGTERM");
  assert.deepEqual(out.split("\n").filter((l) => l.startsWith("spBv1.0/")), [], "retained Sparkplug messages");
});

// Not applicable here, and why:
// - tck-id-payloads-metric-datatype-not-req (SHOULD NOT send datatypes in
//   data): the gateway does, on purpose (gateway/SPARKPLUG.md, Integers):
//   Tahu's JavaScript decoder reads a value by the datatype in its metric.
// - the primary host (tck-id-message-flow-edge-node-birth-publish-phid-*):
//   the gateway's own tests (gateway/src/mqtt/tests.rs) play the STATE
//   messages; this scenario has no primary host.
// - tck-id-payloads-nbirth-edge-node-descriptor (unique in the system): a
//   plant's configuration, not the node's behaviour.
// - intentional disconnects (tck-id-operational-behavior-edge-node-
//   intentional-disconnect-*): the gateway never sends DISCONNECT; a stop
//   closes the connection and the broker publishes the Will (tested above).
