// Camera move → first filtered frame on screen, in Debian's headless chromium against a real
// `lumo serve` (docs/viewer.md, "Latency of a camera move"). Not a test: a measurement that
// prints the distribution and, beside it, the time of one 1-spp trace of the same scene and
// size on the same machine (`lumo render --temporal-eval --reference-spp 0`, same moment), so
// the ratio holds under whatever load the machine carries.
//
//   LUMO_BIN=…/target/release/lumo node latency.mjs [--size 512x512] [--moves 20] [--scene cornell]
//
// One move: the script arms an in-page probe, presses the mouse on the view and moves it
// (an orbit drag). The probe takes the time stamp of the first pointermove the viewer sees
// (the input event) and, at every animation frame, looks for the first frame of the new epoch
// that the viewer has uploaded and drawn: latency = that animation frame's time − the event's
// time stamp (both on the page's performance clock). Between moves the camera rests until
// filtered frames flow again.

import { spawn, execFileSync } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const here = dirname(fileURLToPath(import.meta.url));
const LUMO = process.env.LUMO_BIN || resolve(here, '../../target/release/lumo');
const CHROMIUM_FLAGS = [
  '--headless=new', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-background-networking', '--disable-component-update', '--disable-sync',
  '--no-first-run',
];

function option(name, fallback) {
  const i = process.argv.indexOf(`--${name}`);
  return i > 0 && i + 1 < process.argv.length ? process.argv[i + 1] : fallback;
}
const SIZE = option('size', '512x512');
const MOVES = Number(option('moves', '20'));
const SCENE = option('scene', 'cornell');
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

function quantile(sorted, q) {
  if (sorted.length === 0) return NaN;
  const i = (sorted.length - 1) * q;
  const lo = Math.floor(i);
  const hi = Math.ceil(i);
  return sorted[lo] + (sorted[hi] - sorted[lo]) * (i - lo);
}

// The mean 1-spp trace of SCENE at SIZE over 10 frames of a slow orbit, as --temporal-eval
// times it (the trace with its G-buffer, what the server's frames are made of).
function traceMs() {
  const dir = mkdtempSync(join(tmpdir(), 'lumo-latency-'));
  try {
    execFileSync(LUMO, ['render', SCENE, '--frames', '0..9', '--orbit', '2', '--spp', '1',
      '--size', SIZE, '--temporal-eval', dir, '--reference-spp', '0'], { stdio: 'ignore' });
    const m = readFileSync(join(dir, 'summary.md'), 'utf8').match(/\| trace \(1 spp[^|]*\| ([\d.]+) \|/);
    if (!m) throw new Error(`no trace time in ${dir}/summary.md`);
    return Number(m[1]);
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
}

function serve() {
  return new Promise((resolveUrl, reject) => {
    const p = spawn(LUMO, ['serve', SCENE, '--port', '0', '--size', SIZE], {
      stdio: ['ignore', 'pipe', 'inherit'],
    });
    let out = '';
    p.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/open (http:\/\/\S+)/);
      if (m) resolveUrl({ url: m[1], server: p });
    });
    p.on('exit', (code) => reject(new Error(`lumo serve exited with ${code}`)));
  });
}

// In the page: arm a probe for the next camera move (see the file's comment). The viewer
// notes when it first draws a frame of an epoch (`state.shownEpoch`, `state.shownAt`).
function arm() {
  const probe = { input: null, epoch: window.lumo.counts().epoch };
  window.__probe = probe;
  const onMove = (e) => {
    if (probe.input === null && e.buttons) probe.input = e.timeStamp;
  };
  window.addEventListener('pointermove', onMove, { capture: true });
  probe.done = () => {
    const st = window.lumo.state;
    if (probe.input === null || st.shownEpoch <= probe.epoch) return null;
    window.removeEventListener('pointermove', onMove, { capture: true });
    return st.shownAt - probe.input;
  };
}

async function main() {
  const trace0 = traceMs();
  const { url, server } = await serve();
  const browser = await chromium.launch({
    executablePath: '/usr/bin/chromium',
    headless: false, // --headless=new is among the flags
    args: CHROMIUM_FLAGS,
  });
  const latencies = [];
  try {
    const page = await browser.newPage({ viewport: { width: 1200, height: 900 } });
    await page.goto(url);
    await page.waitForFunction(() => window.lumo && window.lumo.counts().ready, null, { timeout: 60000 });
    await page.selectOption('#mode', 'atrous');
    await page.waitForFunction(() => window.lumo.counts().frameCount > 4, null, { timeout: 60000 });
    const box = await page.locator('#view').boundingBox();
    const cx = box.x + box.width / 2;
    const cy = box.y + box.height / 2;
    for (let i = 0; i < MOVES; i++) {
      await page.evaluate(arm);
      const dx = (i % 2 === 0 ? 1 : -1) * 12;
      await page.mouse.move(cx, cy);
      await page.mouse.down();
      await page.mouse.move(cx + dx, cy);
      await page.mouse.up();
      const ms = await page.waitForFunction(() => window.__probe.done(), null, { timeout: 60000 });
      latencies.push(await ms.jsonValue());
      // Let filtered frames of the still camera flow again before the next move.
      await sleep(400);
    }
  } finally {
    await browser.close();
    server.kill();
  }
  const trace1 = traceMs();
  const trace = (trace0 + trace1) / 2;
  const s = [...latencies].sort((a, b) => a - b);
  const f = (v) => v.toFixed(0);
  console.log(`${SCENE} ${SIZE}, ${MOVES} camera moves: latency ms min ${f(s[0])} · p25 ${f(quantile(s, 0.25))}`
    + ` · median ${f(quantile(s, 0.5))} · p75 ${f(quantile(s, 0.75))} · p90 ${f(quantile(s, 0.9))}`
    + ` · max ${f(s[s.length - 1])}`);
  console.log(`1-spp trace ${trace.toFixed(1)} ms (${trace0.toFixed(1)} before, ${trace1.toFixed(1)} after);`
    + ` median latency / trace = ${(quantile(s, 0.5) / trace).toFixed(2)}`);
  console.log(`all: ${latencies.map(f).join(' ')}`);
}

main().catch((e) => {
  console.error(e);
  process.exit(1);
});
