// bench/viewer/screenshot.mjs — a screenshot of the viewer page for the docs
// (docs/VIEWER.md, README): `volux serve SCENE` in Debian's chromium, the
// given edits applied through the page, the final frame awaited.
//
// Usage: node bench/viewer/screenshot.mjs VOLUX SCENE.json OUT.(png|jpg) ['[{"path":..,"value":..}]'] [SECTIONS]
// SECTIONS: panel sections to fold, e.g. technique,tf (ids sec-technique, sec-tf).
import { spawn } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const [volux, scenePath, out, edits, fold] = process.argv.slice(2);
if (!volux || !scenePath || !out) {
  console.error('usage: node bench/viewer/screenshot.mjs VOLUX SCENE.json OUT.(png|jpg) [EDITS-JSON]');
  process.exit(2);
}
const here = dirname(fileURLToPath(import.meta.url));
const { chromium } = createRequire(join(here, '../../tests/browser/package.json'))('playwright-core');
const server = spawn(volux, ['serve', scenePath, '--port', '0', '--quiet'], {
  stdio: ['ignore', 'pipe', 'inherit'], env: { ...process.env, OMP_WAIT_POLICY: 'passive' },
});
const url = await new Promise((resolve, reject) => {
  let text = '';
  server.stdout.on('data', (d) => {
    text += d;
    const m = text.match(/(http:\/\/127\.0\.0\.1:\d+\/)/);
    if (m) resolve(m[1]);
  });
  server.on('exit', (code) => reject(new Error('server exited with ' + code)));
});
const profile = mkdtempSync(join(tmpdir(), 'volux-shot-'));
const context = await chromium.launchPersistentContext(profile, {
  executablePath: process.env.VOLUX_CHROMIUM || '/usr/bin/chromium', headless: true,
  viewport: { width: 1280, height: 800 },
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run'],
});
const page = await context.newPage();
await page.goto(url);
await page.waitForFunction(() => window.volux && window.volux.ready && window.volux.lastFrame, null, { timeout: 600000 });
if (edits) await page.evaluate((list) => window.volux.edit(list), JSON.parse(edits));
await page.waitForTimeout(500);
await page.waitForFunction(() => {
  const f = window.volux.lastFrame;
  return f && f.kind === 'final' && f.version >= window.volux.state().version;
}, null, { timeout: 600000 });
if (fold) await page.evaluate((ids) => { for (const id of ids) document.getElementById('sec-' + id).open = false; }, fold.split(','));
await page.waitForTimeout(300);
const jpeg = /\.jpe?g$/.test(out);
await page.screenshot({ path: out, type: jpeg ? 'jpeg' : 'png', quality: jpeg ? 82 : undefined });
await context.close();
server.kill('SIGTERM');
await new Promise((r) => server.on('exit', r));
rmSync(profile, { recursive: true, force: true });
console.log('wrote ' + out);
