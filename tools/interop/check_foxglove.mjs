#!/usr/bin/env node
// Check MCAP files / rosbag2 directories against their .expected.json with the npm readers:
// @mcap/core McapIndexedReader (+ @mcap/support decompress handlers), @foxglove/rosmsg and
// @foxglove/rosmsg2-serialization. The same checks as interop_common.py, in JavaScript.
// Usage: AUTOACT_INTEROP_NPM=<npm project with the pinned packages> node check_foxglove.mjs TARGET...
import { open, readFile, stat } from "node:fs/promises";
import { createRequire } from "node:module";
import path from "node:path";

const require = createRequire(path.join(process.env.AUTOACT_INTEROP_NPM ?? ".", "package.json"));
const { McapIndexedReader } = require("@mcap/core");
const { loadDecompressHandlers } = require("@mcap/support");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");

class Mismatch extends Error {}
const INTS = new Set(["byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64"]);
const STAMP = [{ name: "sec", type: "int32" }, { name: "nanosec", type: "uint32" }]; // rosmsg's "time"/"duration"

// ---- targets and expected files ----
const expectedPath = (target, isDir) =>
  path.join(path.dirname(target), `${isDir ? path.basename(target) : path.basename(target, ".mcap")}.expected.json`);

// JSON.parse loses integers above 2^53 (log_time is ~1.7e18 ns): read long integer literals as BigInt.
const MARK = "\u0000autoact-bigint:";
function parseJson(text) {
  const marked = text.replace(/"(?:[^"\\]|\\.)*"|(?<![\d.eE+-])-?\d{16,}(?![\d.eE])/g,
    (tok) => (tok[0] === '"' ? tok : `"\\u0000autoact-bigint:${tok}"`));
  return JSON.parse(marked, (_, v) => (typeof v === "string" && v.startsWith(MARK) ? BigInt(v.slice(MARK.length)) : v));
}

async function loadExpected(target, isDir) {
  const file = expectedPath(target, isDir);
  let text;
  try { text = await readFile(file, "utf8"); } catch { throw new Mismatch(`no ${path.basename(file)} beside it`); }
  const data = parseJson(text);
  if (!Array.isArray(data.messages)) throw new Mismatch(`${path.basename(file)}: no "messages" list`);
  return data;
}

// relative_file_paths of metadata.yaml (block or flow list), without a YAML library.
async function bagFiles(dir) {
  const lines = (await readFile(path.join(dir, "metadata.yaml"), "utf8")).split(/\r?\n/);
  const unquote = (s) => s.trim().replace(/^(['"])(.*)\1$/, "$2");
  const storage = lines.map((l) => l.match(/^\s*storage_identifier:\s*(.*)$/)).find(Boolean);
  if (!storage || unquote(storage[1]) !== "mcap") throw new Mismatch("metadata.yaml storage_identifier is not 'mcap'");
  const at = lines.findIndex((l) => /^\s*relative_file_paths:/.test(l));
  if (at < 0) throw new Mismatch("metadata.yaml has no relative_file_paths");
  const flow = lines[at].match(/relative_file_paths:\s*\[(.*)\]/);
  let names = flow ? flow[1].split(",").map(unquote).filter(Boolean) : [];
  for (let i = at + 1; !flow && i < lines.length; i++) {
    const m = lines[i].match(/^\s*-\s+(.+)$/);
    if (!m) break;
    names.push(unquote(m[1]));
  }
  if (names.length === 0) throw new Mismatch("metadata.yaml lists no relative_file_paths");
  return names.map((n) => path.join(dir, n));
}

// ---- decoded objects -> plain values, and the comparison ----
function toPlain(v) {
  if (ArrayBuffer.isView(v)) return Array.from(v); // Float32Array, Uint8Array, BigInt64Array, ...
  if (Array.isArray(v)) return v.map(toPlain);
  if (v !== null && typeof v === "object") return Object.fromEntries(Object.entries(v).map(([k, x]) => [k, toPlain(x)]));
  return v;
}

const show = (v) => {
  if (typeof v === "number" && Number.isNaN(v)) return "NaN";
  const s = JSON.stringify(v, (_, x) => (typeof x === "bigint" ? Number(x) : x)) ?? String(v);
  return typeof v === "bigint" ? v.toString() : s.length > 80 ? `${s.slice(0, 77)}...` : s;
};
const isInt = (x) => typeof x === "bigint" || Number.isInteger(x);

function floatsEqual(e, g, isFloat32) {
  if (typeof g !== "number") return false;
  if (e === null) return Number.isNaN(g); // NaN is written as null
  if ((typeof e !== "number" && typeof e !== "bigint") || Number.isNaN(g)) return false;
  e = isFloat32 ? Math.fround(Number(e)) : Number(e);
  if (!Number.isFinite(e) || !Number.isFinite(g)) return e === g;
  return Math.abs(e - g) <= Math.max(1e-9, 1e-6 * Math.abs(e));
}

function compareValue(e, g, type, defs, p) {
  if (type === "time" || type === "duration") return compareFields(e, g, STAMP, type, defs, p);
  if (defs.has(type)) return compareFields(e, g, defs.get(type), type, defs, p);
  let ok;
  if (type === "float32" || type === "float64") ok = floatsEqual(e, g, type === "float32");
  else if (type === "bool") ok = typeof e === "boolean" && e === g;
  else if (type === "string" || type === "wstring") ok = typeof e === "string" && e === g;
  else if (INTS.has(type)) ok = isInt(e) && isInt(g) && BigInt(e) === BigInt(g);
  else throw new Mismatch(`${p}: the schema does not define ${type}`);
  if (!ok) throw new Mismatch(`${p}: expected ${show(e)}, got ${show(g)}`);
}

function compareFields(e, g, fields, type, defs, p) {
  if (e === null || typeof e !== "object" || Array.isArray(e)) throw new Mismatch(`${p}: expected JSON is ${show(e)}, not an object for ${type}`);
  if (g === null || typeof g !== "object" || Array.isArray(g)) throw new Mismatch(`${p}: the reader gave ${show(g)}, not a ${type} object`);
  const extra = Object.keys(e).filter((k) => !fields.some((f) => f.name === k)).sort();
  if (extra.length) throw new Mismatch(`${p}: expected JSON has keys that ${type} does not have: ${show(extra)}`);
  for (const f of fields) {
    const q = `${p}.${f.name}`;
    if (!(f.name in e)) throw new Mismatch(`${q}: missing from the expected JSON`);
    if (!(f.name in g)) throw new Mismatch(`${q}: missing from the decoded message`);
    const [ef, gf] = [e[f.name], g[f.name]];
    if (!f.isArray) { compareValue(ef, gf, normType(f.type), defs, q); continue; }
    if (!Array.isArray(ef) || !Array.isArray(gf)) throw new Mismatch(`${q}: expected ${show(ef)}, got ${show(gf)} (both must be lists)`);
    if (ef.length !== gf.length) throw new Mismatch(`${q}: expected ${ef.length} elements, got ${gf.length}`);
    ef.forEach((x, k) => compareValue(x, gf[k], normType(f.type), defs, `${q}[${k}]`));
  }
}

const normType = (t) => t.replace(/^([^/]+)\/msg\/([^/]+)$/, "$1/$2");
const metaKey = ([name, m]) => JSON.stringify([name, Object.keys(m).sort().map((k) => [k, m[k]])]);

function compare(expected, got, metadata) {
  // McapIndexedReader returns messages in log time order (ties in file order): sort stably alike.
  const want = [...expected.messages].sort((a, b) => {
    const [x, y] = [BigInt(a.log_time ?? 0), BigInt(b.log_time ?? 0)];
    return x < y ? -1 : x > y ? 1 : 0;
  });
  if (want.length !== got.length) throw new Mismatch(`expected ${want.length} messages, the reader gave ${got.length}`);
  if (got.length === 0) throw new Mismatch("no messages: a check that checks nothing fails");
  const perTopic = new Map();
  got.forEach((g, n) => {
    const w = want[n];
    const k = (perTopic.get(g.topic) ?? -1) + 1;
    perTopic.set(g.topic, k);
    const where = `${g.topic}[${k}]`, of = `(message ${n} of ${got.length})`;
    for (const key of ["topic", "schema", "log_time", "publish_time"]) {
      const same = typeof g[key] === "bigint" ? isInt(w[key]) && BigInt(w[key]) === g[key] : w[key] === g[key];
      if (!same) throw new Mismatch(`${where} ${of}: ${key}: expected ${show(w[key])}, got ${show(g[key])}`);
    }
    try {
      compareValue(w.message, g.message, normType(g.schema), g.defs, where);
    } catch (err) {
      if (err instanceof Mismatch) err.message += ` ${of}`;
      throw err;
    }
  });
  const wantMeta = (expected.metadata ?? []).map((m) => [m.name, m.metadata]);
  const listed = new Set(wantMeta.map(([name]) => name));
  // rosbag2 writers add a 'rosbag2' record (metadata.yaml text): checked only if listed.
  const gotMeta = metadata.filter(([name]) => name !== "rosbag2" || listed.has(name));
  if (wantMeta.map(metaKey).join("\n") !== gotMeta.map(metaKey).join("\n"))
    throw new Mismatch(`metadata records: expected ${show(wantMeta)}, got ${show(gotMeta)}`);
}

// ---- reading with @mcap/core and the Foxglove decoders ----
async function readMcap(file, decompressHandlers) {
  const name = path.basename(file);
  const fh = await open(file, "r");
  try {
    const size = (await fh.stat()).size;
    const readable = {
      size: async () => BigInt(size),
      read: async (offset, length) => {
        const buf = new Uint8Array(Number(length));
        const { bytesRead } = await fh.read(buf, 0, buf.length, Number(offset));
        if (bytesRead !== buf.length) throw new Error(`${name}: short read at ${offset}`);
        return buf;
      },
    };
    const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
    if (reader.header.profile !== "ros2") throw new Mismatch(`${name}: header profile is ${show(reader.header.profile)}, not "ros2"`);
    if (reader.chunkIndexes.length === 0) throw new Mismatch(`${name}: summary has no chunk indexes (files must be chunked and indexed)`);
    const decoders = new Map();
    for (const [id, s] of reader.schemasById) {
      if (s.encoding !== "ros2msg") throw new Mismatch(`${name}: schema ${s.name} has encoding ${show(s.encoding)}, not "ros2msg"`);
      const parsed = parse(new TextDecoder().decode(s.data), { ros2: true });
      const defs = new Map(parsed.map((d, i) => [normType(i === 0 ? s.name : d.name), d.definitions.filter((f) => !f.isConstant)]));
      decoders.set(id, { reader: new MessageReader(parsed), defs, name: s.name });
    }
    for (const c of reader.channelsById.values()) {
      if (c.messageEncoding !== "cdr") throw new Mismatch(`${name}: channel ${c.topic} has message encoding ${show(c.messageEncoding)}, not "cdr"`);
      if (!decoders.has(c.schemaId)) throw new Mismatch(`${name}: channel ${c.topic} has no schema`);
    }
    const messages = [];
    for await (const m of reader.readMessages()) {
      const c = reader.channelsById.get(m.channelId);
      const d = decoders.get(c.schemaId);
      messages.push({ topic: c.topic, schema: d.name, log_time: m.logTime, publish_time: m.publishTime,
        message: toPlain(d.reader.readMessage(m.data)), defs: d.defs });
    }
    const count = reader.statistics?.messageCount;
    if (count !== undefined && count !== BigInt(messages.length)) throw new Mismatch(`${name}: statistics say ${count} messages, read ${messages.length}`);
    const metadata = [];
    for await (const r of reader.readMetadata()) metadata.push([r.name, Object.fromEntries(r.metadata)]);
    return { messages, metadata };
  } finally {
    await fh.close();
  }
}

const targets = process.argv.slice(2);
if (targets.length === 0) {
  console.error("usage: node check_foxglove.mjs FILE.mcap|ROSBAG2_DIR ...");
  process.exit(2);
}
const decompressHandlers = await loadDecompressHandlers();
let failed = 0;
for (const target of targets) {
  try {
    const isDir = (await stat(target)).isDirectory();
    const expected = await loadExpected(target, isDir);
    const all = { messages: [], metadata: [] };
    for (const file of isDir ? await bagFiles(target) : [target]) {
      const { messages, metadata } = await readMcap(file, decompressHandlers);
      all.messages.push(...messages);
      all.metadata.push(...metadata);
    }
    compare(expected, all.messages, all.metadata);
    console.log(`ok foxglove ${target}: ${all.messages.length} messages`);
  } catch (err) {
    failed++;
    console.log(`FAIL foxglove ${target}: ${err instanceof Mismatch ? err.message : `${err.name}: ${err.message}`}`);
    if (!(err instanceof Mismatch)) console.error(err.stack);
  }
}
process.exitCode = failed ? 1 : 0;
