// tests/browser/viewer_test.mjs — the viewer page in a real browser: Debian's
// chromium driven by playwright-core (no browser download). Loads the page,
// drags a transfer-function point and checks the image changed, toggles a
// light, switches the technique, saves the scene and the image through the
// page's buttons and checks that `volux render` of the saved scene gives the
// saved image bit for bit; on a time-varying volume, moves the time-step
// slider and checks the image, the saved scene and `volux render
// --time-step`. Screenshots go to the artefact folder; the page-measured
// edit → frame latencies are printed.
//
// Usage: node viewer_test.mjs VOLUX ARTEFACT_DIR
// Exit status 77 (ctest: skipped) when chromium or playwright-core is absent.
import { spawn, execFileSync } from 'node:child_process';
import { existsSync, mkdirSync, mkdtempSync, writeFileSync, readFileSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const [volux, artefacts] = process.argv.slice(2);
const here = dirname(fileURLToPath(import.meta.url));
const CHROMIUM = process.env.VOLUX_CHROMIUM || '/usr/bin/chromium';
if (!existsSync(CHROMIUM)) { console.log(`skipped: no ${CHROMIUM}`); process.exit(77); }
let chromium;
try {
  ({ chromium } = createRequire(join(here, 'package.json'))('playwright-core'));
} catch (e) {
  console.log('skipped: playwright-core is not installed (make test-deps, or npm ci in tests/browser)');
  process.exit(77);
}
mkdirSync(artefacts, { recursive: true });
const work = mkdtempSync(join(tmpdir(), 'volux-browser-'));

const scene = {
  volume: { procedural: 'phantom', dims: [64, 64, 64] },
  transfer_function: {
    color: [[0, 0.2, 0.3, 0.6], [60, 0.9, 0.5, 0.3], [140, 0.95, 0.9, 0.8], [255, 1, 1, 1]],
    opacity: [[0, 0], [30, 0], [60, 0.05], [140, 0.3], [255, 0.9]],
  },
  camera: { orbit: { azimuth: 30, elevation: 20 }, fov_y: 30 },
  lights: [
    { type: 'directional', direction: [-0.5, -0.7, -0.5], irradiance: 1.2 },
    { type: 'point', position: [60, 30, 80], color: [0.4, 0.5, 1], intensity: 3000 },
  ],
  background: [0.02, 0.02, 0.03],
  render: { technique: 'ea', width: 160, height: 120, spp: 2 },
};
const scenePath = join(work, 'scene.json');
writeFileSync(scenePath, JSON.stringify(scene, null, 1));

let failures = 0;
function check(cond, what) {
  console.log(`${cond ? 'ok  ' : 'FAIL'} ${what}`);
  if (!cond) failures++;
}

// ---------------------------------------------------------------- server
const servers = [];
async function startServer(path) {
  const server = spawn(volux, ['serve', path, '--port', '0', '--quiet', '--idle-ms', '50'], { stdio: ['ignore', 'pipe', 'inherit'] });
  servers.push(server);
  return new Promise((resolve, reject) => {
    let out = '';
    const t = setTimeout(() => reject(new Error('server did not start')), 60000);
    server.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/(http:\/\/127\.0\.0\.1:\d+\/)/);
      if (m) { clearTimeout(t); resolve(m[1]); }
    });
    server.on('exit', (code) => reject(new Error('server exited with ' + code)));
  });
}
const url = await startServer(scenePath);

const profile = mkdtempSync(join(tmpdir(), 'volux-chromium-'));
const context = await chromium.launchPersistentContext(profile, {
  executablePath: CHROMIUM,
  headless: true,
  acceptDownloads: true,
  viewport: { width: 1200, height: 780 },
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
    '--disable-component-update', '--disable-sync', '--no-first-run'],
});
const page = await context.newPage();
page.on('pageerror', (e) => { console.log('page error: ' + e.message); failures++; });

async function frameBytes() {
  return page.evaluate(async () => {
    const r = await fetch('/api/frame?wait=final&format=png&timeout=60000');
    return Array.from(new Uint8Array(await r.arrayBuffer()));
  });
}
// The final frame of the edit the page sent last.
async function waitFinal(after) {
  await page.waitForFunction((v) => {
    const f = window.volux.lastFrame;
    return f && f.kind === 'final' && f.version >= v;
  }, after, { timeout: 120000 });
}
const version = () => page.evaluate(() => window.volux.version);
const same = (a, b) => a.length === b.length && a.every((x, i) => x === b[i]);

try {
  await page.goto(url);
  await page.waitForFunction(() => window.volux && window.volux.ready, null, { timeout: 60000 });
  await waitFinal(0);
  await page.screenshot({ path: join(artefacts, 'viewer_loaded.png') });
  const first = await frameBytes();
  check(first.length > 100, 'page loaded and shows the final frame');

  // Drag the 4th opacity point (s = 140) upwards.
  const box = await page.locator('#tf').boundingBox();
  const st = await page.evaluate(() => window.volux.state());
  const [lo, hi] = st.volume.range;
  const px = (s, v) => [box.x + (6 + (s - lo) / (hi - lo) * (320 - 12)) * box.width / 320,
    box.y + (150 - 6 - v * (150 - 12)) * box.height / 150];
  const [x0, y0] = px(140, 0.3);
  await page.mouse.move(x0, y0);
  await page.mouse.down();
  for (let k = 1; k <= 8; k++) await page.mouse.move(x0, y0 - k * 6, { steps: 2 });
  await page.mouse.up();
  await page.waitForFunction(() => window.volux.version > 0, null, { timeout: 30000 });
  await page.waitForTimeout(300);
  const v1 = await version();
  await waitFinal(v1);
  const afterTF = await frameBytes();
  const tfNow = await page.evaluate(async () => (await (await fetch('/api/scene')).json()).transfer_function.opacity);
  check(tfNow[3][1] > 0.35, `TF point dragged (opacity at s=140: 0.3 → ${tfNow[3][1]})`);
  check(!same(first, afterTF), 'the image changed after the TF drag');
  await page.screenshot({ path: join(artefacts, 'viewer_tf_drag.png') });

  // Switch the technique.
  await page.selectOption('#technique', 'shaded');
  await page.waitForFunction(() => window.volux.state().resolved.render.technique === 'shaded', null, { timeout: 30000 });
  await waitFinal(await version());
  const afterShaded = await frameBytes();
  check(!same(afterTF, afterShaded), 'the image changed after switching to shaded');
  const stats = await page.evaluate(async () => (await fetch('/api/stats')).json());
  check(stats.technique === 'shaded', `technique switched (stats say ${stats.technique})`);
  const params = await page.locator('#params input').count();
  check(params >= 3, `parameter form generated from the table (${params} inputs)`);
  // Toggle the first light off (shaded reads the lights; ea does not).
  await page.locator('.light[data-index="0"] .toggle').click();
  await page.waitForFunction(() => window.volux.state().scene.lights[0].enabled === false, null, { timeout: 30000 });
  await waitFinal(await version());
  const afterLight = await frameBytes();
  check(!same(afterShaded, afterLight), 'the image changed after switching light 0 off');

  // A parameter edit through the generated form.
  await page.locator('#params input[data-param="gradient_threshold"]').fill('0.05');
  await page.locator('#params input[data-param="gradient_threshold"]').dispatchEvent('change');
  await page.waitForFunction(() => (window.volux.state().scene.techniques || {}).shaded, null, { timeout: 30000 });
  await waitFinal(await version());
  await page.screenshot({ path: join(artefacts, 'viewer_shaded.png') });

  // Orbit the camera by dragging on the image.
  const stage = await page.locator('#stage').boundingBox();
  await page.mouse.move(stage.x + stage.width / 2, stage.y + stage.height / 2);
  await page.mouse.down();
  await page.mouse.move(stage.x + stage.width / 2 + 80, stage.y + stage.height / 2 + 20, { steps: 6 });
  await page.mouse.up();
  await page.waitForFunction(() => {
    const o = (window.volux.state().scene.camera || {}).orbit;
    return o && Math.abs(o.azimuth - 30) > 5;
  }, null, { timeout: 30000 });
  await waitFinal(await version());

  // Issue 30's controls. The busy indicator: switching to `single`
  // prepares its light cache, announced with stage and percent.
  await page.selectOption('#technique', 'single');
  await page.waitForFunction(() => window.volux.state().resolved.render.technique === 'single', null, { timeout: 30000 });
  await waitFinal(await version());
  const busy = await page.evaluate(() => window.volux.busyLog || []);
  check(busy.some((b) => /preparing single/.test(b.task) && Number.isFinite(b.percent)),
    `busy indicator with stage and percent (${busy.map((b) => `${b.task} ${b.percent}`).slice(0, 3).join('; ')})`);
  // Automatic exposure: switching technique set render.exposure from the frame.
  const st30 = await page.evaluate(async () => (await fetch('/api/stats')).json());
  check(st30.auto_exposures >= 1 && st30.auto_exposure === (await page.evaluate(() => window.volux.state().resolved.render.exposure)),
    `auto exposure applied on the switch (EV ${st30.auto_exposure}, ${st30.auto_exposures} times)`);
  await page.click('#v-expose');
  await page.waitForFunction((n) => fetch('/api/stats').then((r) => r.json()).then((s) => s.auto_exposures > n), st30.auto_exposures, { timeout: 60000, polling: 200 });
  check(true, '"expose now" recomputed the exposure');
  // Denoise toggle (a viewer switch, not the scene's).
  await page.click('#v-denoise');
  await page.waitForFunction(() => fetch('/api/stats').then((r) => r.json()).then((s) => s.denoise === false), null, { timeout: 30000, polling: 200 });
  await page.click('#v-denoise');
  await page.waitForFunction(() => fetch('/api/stats').then((r) => r.json()).then((s) => s.denoise === true), null, { timeout: 30000, polling: 200 });
  check(await page.locator('#v-denoise').isChecked(), 'denoise toggled off and on');
  // Background colour, as displayed: stored divided by 2^exposure.
  await page.locator('#v-background').fill('#304050');
  await page.waitForFunction(() => {
    const s = window.volux.state(), bg = s.scene.background || [0, 0, 0], k = 2 ** s.resolved.render.exposure;
    return Math.abs(bg[2] * k - 0.0802) < 0.01; // #50 in sRGB = 0.0802 linear
  }, null, { timeout: 30000 });
  await waitFinal(await version());
  check(true, 'background colour set from the page');
  // A view button: the camera looks from the anterior side (+z without patient axes).
  await page.click('#v-views button[data-view="anterior"]');
  await page.waitForFunction(() => {
    const c = window.volux.state().scene.camera || {}, C = window.volux.state().volume.center;
    return c.eye && c.eye[2] > C[2] && Math.abs(c.eye[0] - C[0]) < 1e-3;
  }, null, { timeout: 30000 });
  await waitFinal(await version());
  const axesInk = await page.evaluate(() => {
    const c = document.getElementById('v-axes'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;
    for (let i = 3; i < d.length; i += 4) n += d[i] > 0;
    return n;
  });
  check(axesInk > 20, `anterior view button moved the camera; orientation axes drawn (${axesInk} px)`);
  // Slice views: open the section, three slices arrive; a slider loads another one.
  await page.click('#sec-slices > summary');
  await page.waitForFunction(() => ['x', 'y', 'z'].every((a) => document.getElementById('slice-' + a).naturalWidth === 64), null, { timeout: 30000 });
  const src0 = await page.evaluate(() => document.getElementById('slice-z').src);
  await page.locator('#slice-z-i').fill('10');
  await page.waitForFunction((s) => document.getElementById('slice-z').src !== s, src0, { timeout: 30000 });
  await page.selectOption('#s-mode', 'tf');
  await page.waitForFunction((s) => document.getElementById('slice-z').src !== s, src0, { timeout: 30000 });
  check(true, 'slice views load, follow their slider and the colour mode');
  await page.screenshot({ path: join(artefacts, 'viewer_view_slices.png') });
  // Crop and clip (issue 30): the crop box's x max slider, then a plane
  // added and moved; the saved scene below carries both, and `volux render`
  // of it must give the page's final frame.
  const beforeClip = await frameBytes();
  await page.locator('#sec-clip summary').click();
  await page.locator('#clip-max-x').focus();
  for (let k = 0; k < 50; k++) await page.keyboard.press('ArrowLeft');
  await page.waitForFunction(() => (((window.volux.state().scene.clip || {}).box || {}).max || [])[0] !== undefined,
    null, { timeout: 30000 });
  await page.waitForTimeout(300);
  await waitFinal(await version());
  const afterCrop = await frameBytes();
  check(!same(beforeClip, afterCrop), 'the image changed after cropping with the x max slider');
  await page.click('#clip-plane-add');
  await page.waitForFunction(() => ((window.volux.state().scene.clip || {}).planes || []).length === 1, null,
    { timeout: 30000 });
  await page.locator('.clip-plane-normal').nth(1).fill('1');
  await page.locator('.clip-plane-normal').nth(1).dispatchEvent('change');
  await page.locator('.clip-plane-offset').first().focus();
  for (let k = 0; k < 30; k++) await page.keyboard.press('ArrowRight');
  await page.waitForFunction(() => {
    const p = ((window.volux.state().scene.clip || {}).planes || [])[0];
    return p && p.normal[1] === 1;
  }, null, { timeout: 30000 });
  await page.waitForTimeout(300);
  await waitFinal(await version());
  const afterPlane = await frameBytes();
  check(!same(afterCrop, afterPlane), 'the image changed after adding and moving a clipping plane');
  await page.screenshot({ path: join(artefacts, 'viewer_clip.png') });

  // Save the scene and the image with the page's buttons.
  const [sceneDl] = await Promise.all([page.waitForEvent('download'), page.click('#save-scene')]);
  const savedScene = join(work, 'saved.json');
  await sceneDl.saveAs(savedScene);
  const [imageDl] = await Promise.all([page.waitForEvent('download', { timeout: 120000 }), page.click('#save-image')]);
  const savedImage = join(artefacts, 'viewer_saved.png');
  await imageDl.saveAs(savedImage);
  const cliImage = join(work, 'cli.png');
  execFileSync(volux, ['render', savedScene, '-o', cliImage, '--quiet']);
  const cmp = execFileSync(volux, ['compare', savedImage, cliImage, '--json']).toString();
  const err = JSON.parse(cmp);
  check(err.max_abs === 0, `volux render of the saved scene = the saved image (max_abs ${err.max_abs})`);
  check(JSON.parse(readFileSync(savedScene)).lights[0].enabled === false, 'the saved scene has the light switched off');
  const savedClip = JSON.parse(readFileSync(savedScene)).clip || {};
  check(savedClip.box && savedClip.planes && savedClip.planes.length === 1, 'the saved scene has the crop box and the plane');

  const lat = await page.evaluate(() => window.volux.latencies);
  const sorted = [...lat].sort((a, b) => a - b);
  console.log(`page-measured edit → frame latency over ${lat.length} edits: median ${sorted[Math.floor((sorted.length - 1) / 2)]?.toFixed(1)} ms, max ${sorted[sorted.length - 1]?.toFixed(1)} ms`);
  const errors = await page.evaluate(() => window.volux.errors);
  check(errors.length === 0, `no error shown (${errors.join('; ')})`);
  await page.screenshot({ path: join(artefacts, 'viewer_final.png') });

  // A time-varying volume (the drifting procedural cloud): the page shows
  // the step slider; moving it renders that step, and the saved scene
  // renders the same with the CLI, as does `volux render --time-step`.
  const seqScene = {
    volume: { procedural: 'cloud', dims: [48, 48, 48], steps: 6, time_per_step: 0.2 },
    transfer_function: { color: [[0, 0.6, 0.7, 1], [255, 1, 1, 1]], opacity: [[0, 0], [40, 0.05], [255, 0.9]] },
    camera: { orbit: { azimuth: 20, elevation: 15 } },
    render: { technique: 'ea', width: 160, height: 120, spp: 1 },
  };
  const seqPath = join(work, 'sequence.json');
  writeFileSync(seqPath, JSON.stringify(seqScene, null, 1));
  const seqUrl = await startServer(seqPath);
  await page.goto(seqUrl);
  await page.waitForFunction(() => window.volux && window.volux.ready, null, { timeout: 60000 });
  await waitFinal(0);
  const step0 = await frameBytes();
  const slider = page.locator('#time-step');
  check(await slider.isVisible(), 'the time-step slider is shown for a sequence');
  check(await slider.getAttribute('max') === '5', `the slider spans the 6 steps (max ${await slider.getAttribute('max')})`);
  await slider.focus();
  for (let k = 0; k < 3; k++) await page.keyboard.press('ArrowRight');
  await page.waitForFunction(() => (window.volux.state().sequence || {}).step === 3, null, { timeout: 30000 });
  await waitFinal(await version());
  const step3 = await frameBytes();
  check(!same(step0, step3), 'the image changed after moving the slider to step 3');
  await page.screenshot({ path: join(artefacts, 'viewer_time_step.png') });
  const [seqDl] = await Promise.all([page.waitForEvent('download'), page.click('#save-scene')]);
  const seqSaved = join(work, 'sequence_saved.json');
  await seqDl.saveAs(seqSaved);
  check(JSON.parse(readFileSync(seqSaved)).render.time_step === 3, 'the saved scene keeps time step 3');
  const [seqImg] = await Promise.all([page.waitForEvent('download', { timeout: 120000 }), page.click('#save-image')]);
  const seqImage = join(artefacts, 'viewer_time_step_saved.png');
  await seqImg.saveAs(seqImage);
  for (const [args, what] of [[[seqSaved], 'the saved scene'], [[seqPath, '--time-step', '3'], '--time-step 3']]) {
    const out = join(work, 'sequence_cli.png');
    execFileSync(volux, ['render', ...args, '-o', out, '--quiet']);
    const d = JSON.parse(execFileSync(volux, ['compare', seqImage, out, '--json']).toString());
    check(d.max_abs === 0, `volux render of ${what} = the saved image (max_abs ${d.max_abs})`);
  }
  const seqErrors = await page.evaluate(() => window.volux.errors);
  check(seqErrors.length === 0, `no error shown on the sequence page (${seqErrors.join('; ')})`);
} catch (e) {
  console.log('FAIL ' + e.stack);
  failures++;
  await page.screenshot({ path: join(artefacts, 'viewer_failure.png') }).catch(() => {});
} finally {
  await context.close();
  for (const server of servers) {
    const exited = server.exitCode !== null ? Promise.resolve(server.exitCode)
      : new Promise((r) => server.on('exit', r));
    server.kill('SIGTERM');
    const code = await exited;
    check(code === 0, `server stopped cleanly (exit ${code})`);
  }
  rmSync(profile, { recursive: true, force: true });
  rmSync(work, { recursive: true, force: true });
}
console.log(`${failures ? 'FAILED' : 'passed'}: ${failures} failure(s)`);
process.exit(failures ? 1 : 0);
