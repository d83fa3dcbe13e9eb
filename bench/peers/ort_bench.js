#!/usr/bin/env node
// Times the U-Net forward in ONNX Runtime (npm onnxruntime-node, CPU execution provider).
//
// Usage: node bench/peers/ort_bench.js --model FILE.onnx [--check FILE.json] [--batches 1,1024]
//            [--threads 1] [--extra 1024:2] [--reps 10] [--min-time 0.2] [--warmup 0.3]
//
// Session options: intraOpNumThreads = threads, interOpNumThreads = 1, graphOptimizationLevel 'all',
// executionMode 'sequential'. For each (batch, threads) case: warm-up for --warmup seconds, then
// --reps repetitions, each timing a block of n back-to-back session.run calls (n chosen so a block
// lasts about --min-time seconds); the reported time is the median over repetitions of the block
// mean, like Google Benchmark's `median` aggregate. Times include the Node binding's per-call
// overhead (tensor wrapping, the promise), which is part of using ONNX Runtime from Node.
//
// --check FILE.json ({"input": [...], "output": [...], "shape": [B,2,5,5]}, written by
// bench/peers/torch_bench.py) compares ORT's output with PyTorch's before timing.
//
// Prints one JSON object on stdout.
'use strict';

const fs = require('fs');
const path = require('path');

function parseArgs(argv) {
  const a = { batches: [1, 1024], threads: 1, extra: [], reps: 10, minTime: 0.2, warmup: 0.3 };
  for (let i = 2; i < argv.length; i++) {
    const k = argv[i];
    const v = () => {
      if (i + 1 >= argv.length) throw new Error(`${k} needs a value`);
      return argv[++i];
    };
    if (k === '--model') a.model = v();
    else if (k === '--check') a.check = v();
    else if (k === '--batches') a.batches = v().split(',').map(Number);
    else if (k === '--threads') a.threads = Number(v());
    else if (k === '--extra') a.extra = v().split(',').filter(Boolean).map((s) => s.split(':').map(Number));
    else if (k === '--reps') a.reps = Number(v());
    else if (k === '--min-time') a.minTime = Number(v());
    else if (k === '--warmup') a.warmup = Number(v());
    else throw new Error(`unknown argument ${k}`);
  }
  if (!a.model) throw new Error('--model FILE.onnx is required');
  return a;
}

function loadOrt() {
  try {
    return require('onnxruntime-node');
  } catch (e) {
    throw new Error(
      `cannot load onnxruntime-node (${e.message}); run: (cd ${path.relative(process.cwd(), __dirname) || '.'} && npm ci --ignore-scripts)`);
  }
}

function median(xs) {
  const s = [...xs].sort((p, q) => p - q);
  const m = s.length >> 1;
  return s.length % 2 ? s[m] : (s[m - 1] + s[m]) / 2;
}

const nowS = () => Number(process.hrtime.bigint()) / 1e9;

async function makeSession(ort, model, threads) {
  return ort.InferenceSession.create(model, {
    executionProviders: ['cpu'],
    intraOpNumThreads: threads,
    interOpNumThreads: 1,
    graphOptimizationLevel: 'all',
    executionMode: 'sequential',
  });
}

function randomInput(batch) {
  // Deterministic values in [-1.2, 1.2] (the calibrated range plus margin), as in the fixtures.
  const x = new Float32Array(batch * 2 * 5 * 5);
  let s = 12345;
  for (let i = 0; i < x.length; i++) {
    s = (Math.imul(s, 1103515245) + 12345) >>> 0;
    x[i] = (s / 4294967296) * 2.4 - 1.2;
  }
  return x;
}

async function timeCase(ort, session, batch, threads, opt) {
  const feeds = { input: new ort.Tensor('float32', randomInput(batch), [batch, 2, 5, 5]) };
  const runN = async (n) => {
    const t0 = nowS();
    for (let i = 0; i < n; i++) await session.run(feeds);
    return nowS() - t0;
  };
  // Warm-up, also estimating the time of one run.
  let n = 0;
  const w0 = nowS();
  do {
    await session.run(feeds);
    n++;
  } while (nowS() - w0 < opt.warmup);
  const perRun = (nowS() - w0) / n;
  const iters = Math.max(1, Math.round(opt.minTime / perRun));
  const blockMeans = [];
  for (let r = 0; r < opt.reps; r++) blockMeans.push((await runN(iters)) / iters);
  const med = median(blockMeans);
  return {
    batch,
    threads,
    reps: opt.reps,
    iters_per_rep: iters,
    median_s_per_run: med,
    median_us_per_frame: (med * 1e6) / batch,
    frames_per_s: batch / med,
    rep_means_s: blockMeans,
  };
}

async function check(ort, session, file) {
  const c = JSON.parse(fs.readFileSync(file, 'utf8'));
  const out = await session.run({ input: new ort.Tensor('float32', Float32Array.from(c.input), c.shape) });
  const y = out.output.data;
  if (y.length !== c.output.length) throw new Error(`check: ORT output has ${y.length} values, expected ${c.output.length}`);
  let maxDiff = 0;
  for (let i = 0; i < y.length; i++) maxDiff = Math.max(maxDiff, Math.abs(y[i] - c.output[i]));
  if (!(maxDiff < 1e-4)) throw new Error(`check: ORT output differs from PyTorch's by ${maxDiff} (> 1e-4)`);
  return maxDiff;
}

async function main() {
  const opt = parseArgs(process.argv);
  if (!fs.existsSync(opt.model)) throw new Error(`model ${opt.model} not found`);
  const ort = loadOrt();
  const version = require('onnxruntime-node/package.json').version;
  const cases = opt.batches.map((b) => [b, opt.threads]).concat(opt.extra);
  const sessions = new Map();
  const results = [];
  let maxDiff = null;
  for (const [batch, threads] of cases) {
    if (!sessions.has(threads)) sessions.set(threads, await makeSession(ort, opt.model, threads));
    const session = sessions.get(threads);
    if (opt.check && maxDiff === null) maxDiff = await check(ort, session, opt.check);
    results.push(await timeCase(ort, session, batch, threads, opt));
  }
  process.stdout.write(JSON.stringify({
    engine: 'onnxruntime-node',
    version,
    node: process.version,
    model: path.basename(opt.model),
    check_max_abs_diff_vs_torch: maxDiff,
    results,
  }, null, 1) + '\n');
}

main().catch((e) => {
  process.stderr.write(`ort_bench: ${e.message}\n`);
  process.exit(1);
});
