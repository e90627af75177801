// The 3D replay pages in a real browser: Debian's chromium, headless, driven by playwright-core
// (viz/web/node_modules; it never downloads a browser). For every page, from a file URL:
//  - the page reports its frames loaded (as many as its data holds) and logs no error;
//  - its forward kinematics put the wheels where robot_model's do (the page carries the C++
//    values of the apex frame);
//  - scrubbed to the take-off and to the apex with a fixed side camera, the screenshots show the
//    robot's body where the page projects the data's base position, and the body moved between
//    the two pictures as the data moved it.
// Also checks that the PNG and GIF files given after --images are whole.
//
// node browser_test.mjs --web VIZ_WEB_DIR --out SCREENSHOT_DIR [--images F...] --pages P...
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import zlib from 'node:zlib';
import { pathToFileURL } from 'node:url';

const args = { pages: [], images: [] };
for (let i = 2, list = null; i < process.argv.length; ++i) {
  const a = process.argv[i];
  if (a === '--web' || a === '--out') args[a.slice(2)] = process.argv[++i];
  else if (a === '--pages' || a === '--images') list = args[a.slice(2)];
  else if (list) list.push(a);
  else throw new Error('unexpected argument ' + a);
}
const { chromium } = await import(pathToFileURL(path.join(args.web, 'node_modules', 'playwright-core', 'index.mjs')));
fs.mkdirSync(args.out, { recursive: true });

const failures = [];
const check = (ok, what) => {
  console.log((ok ? 'ok    ' : 'FAIL  ') + what);
  if (!ok) failures.push(what);
};

// ---- PNG decoding (8-bit RGB/RGBA, not interlaced: what chromium and cairo write) --------
function decodePng(buf) {
  if (buf.readUInt32BE(0) !== 0x89504e47) throw new Error('not a PNG');
  let at = 8, width = 0, height = 0, type = 0;
  const idat = [];
  while (at < buf.length) {
    const len = buf.readUInt32BE(at), kind = buf.toString('ascii', at + 4, at + 8);
    const body = buf.subarray(at + 8, at + 8 + len);
    if (kind === 'IHDR') {
      width = body.readUInt32BE(0); height = body.readUInt32BE(4); type = body[9];
      if (body[8] !== 8 || body[12] !== 0 || (type !== 2 && type !== 6))
        throw new Error('PNG: only 8-bit RGB(A) without interlace is read here');
    } else if (kind === 'IDAT') idat.push(body);
    else if (kind === 'IEND') break;
    at += 12 + len;
  }
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const bpp = type === 6 ? 4 : 3, stride = width * bpp;
  const px = Buffer.alloc(width * height * 3);
  let prev = Buffer.alloc(stride), line = Buffer.alloc(stride);
  for (let y = 0; y < height; ++y) {
    const f = raw[y * (stride + 1)], src = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; ++x) {
      const a = x >= bpp ? line[x - bpp] : 0, b = prev[x], c = x >= bpp ? prev[x - bpp] : 0;
      let p = 0;
      if (f === 1) p = a; else if (f === 2) p = b; else if (f === 3) p = (a + b) >> 1;
      else if (f === 4) { const pa = Math.abs(b - c), pb = Math.abs(a - c), pc = Math.abs(a + b - 2 * c);
                          p = pa <= pb && pa <= pc ? a : pb <= pc ? b : c; }
      line[x] = (src[x] + p) & 255;
    }
    for (let x = 0; x < width; ++x) for (let k = 0; k < 3; ++k) px[(y * width + x) * 3 + k] = line[x * bpp + k];
    [prev, line] = [line, prev];
  }
  return { width, height, px };
}

// The robot's body: its orange (0xe07b24 lit) is the only strongly saturated orange drawn.
function bodyPixels(img, rect) {
  let n = 0, sx = 0, sy = 0;
  const [x0, y0, w, h] = rect.map(Math.round);
  for (let y = Math.max(0, y0); y < Math.min(img.height, y0 + h); ++y)
    for (let x = Math.max(0, x0); x < Math.min(img.width, x0 + w); ++x) {
      const i = (y * img.width + x) * 3, r = img.px[i], g = img.px[i + 1], b = img.px[i + 2];
      const max = Math.max(r, g, b), min = Math.min(r, g, b);
      if (max < 90 || (max - min) / max < 0.7 || r !== max) continue;
      const hue = 60 * (g - b) / (max - min);  // red is the maximum
      if (hue < 15 || hue > 42) continue;
      ++n; sx += x; sy += y;
    }
  return { n, x: sx / n, y: sy / n };
}

// ---- images ------------------------------------------------------------------------------
for (const file of args.images) {
  const buf = fs.readFileSync(file);
  if (file.endsWith('.png')) {
    const img = decodePng(buf);
    const counts = new Map();
    for (let i = 0; i < img.px.length; i += 3) {
      const key = img.px.readUIntBE(i, 3);
      counts.set(key, (counts.get(key) || 0) + 1);
    }
    const background = Math.max(...counts.values()) / (img.width * img.height);
    check(background < 0.98, `${path.basename(file)}: a whole ${img.width}x${img.height} PNG with a drawing (${(100 * (1 - background)).toFixed(1)} % not background)`);
  } else {
    let ok = buf.toString('ascii', 0, 6) === 'GIF89a', frames = 0, at = 13;
    if (buf[10] & 0x80) at += 3 << ((buf[10] & 7) + 1);
    const skip = () => { while (at < buf.length && buf[at] !== 0) at += 1 + buf[at]; ++at; };
    while (ok && at < buf.length && buf[at] !== 0x3b) {
      if (buf[at] === 0x21) { at += 2; skip(); }
      else if (buf[at] === 0x2c) { const fl = buf[at + 9]; at += 10; if (fl & 0x80) at += 3 << ((fl & 7) + 1); at += 1; skip(); ++frames; }
      else ok = false;
    }
    ok = ok && buf[at] === 0x3b;
    check(ok && frames >= 2, `${path.basename(file)}: a whole animated GIF (${frames} frames, ${(buf.length / 1024).toFixed(0)} KiB)`);
  }
}

// ---- pages -------------------------------------------------------------------------------
const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'wj-chromium-'));
const context = await chromium.launchPersistentContext(profile, {
  executablePath: '/usr/bin/chromium',
  headless: true,
  viewport: { width: 1280, height: 760 },
  deviceScaleFactor: 1,
  args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
         '--disable-background-networking', '--disable-component-update', '--disable-sync',
         // WebGL without a GPU: SwiftShader, asked for explicitly (the page is trusted).
         '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
try {
  for (const file of args.pages) {
    const name = path.basename(file, '.html');
    const page = await context.newPage();
    const errors = [];
    page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
    page.on('pageerror', (e) => errors.push(String(e)));
    await page.goto(pathToFileURL(path.resolve(file)).href);
    await page.waitForFunction(() => ['loaded', 'error'].includes(document.body.dataset.status), null, { timeout: 90000 });
    const state = await page.evaluate(() => ({
      ready: window.wjReplay.ready, frames: window.wjReplay.frameCount,
      dataFrames: JSON.parse(document.getElementById('wj-data').textContent).frames.t.length,
      events: window.wjReplay.events, check: window.wjReplay.check,
    }));
    check(state.ready && state.frames === state.dataFrames && state.frames > 10,
          `${name}: the page reports its ${state.frames} frames loaded (data: ${state.dataFrames})`);

    const fk = await page.evaluate((i) => window.wjReplay.wheelCenters(i), state.check.frame);
    const fkError = Math.max(...fk.flatMap((c, leg) => c.map((v, k) => Math.abs(v - state.check.wheel_centers[leg][k]))));
    check(fkError < 2e-3, `${name}: the page's wheel centres at the apex match robot_model's (max error ${(1000 * fkError).toFixed(2)} mm)`);

    // Fixed side camera, then scrub with the slider as a user would.
    await page.uncheck('#follow');
    await page.selectOption('#viewpoint', 'side');
    const measured = {};
    for (const [label, index] of [['takeoff', state.events.takeoff_index], ['apex', state.events.apex_index]]) {
      await page.fill('#scrub', String(index));
      const at = await page.evaluate(() => window.wjReplay.current);
      check(at === index, `${name}: scrubbed to the ${label} (frame ${index})`);
      const shot = path.join(args.out, `${name}-${label}.png`);
      const img = decodePng(await page.screenshot({ path: shot }));
      const info = await page.evaluate((i) => ({ projected: window.wjReplay.project(window.wjReplay.frame(i).base.slice(0, 3)),
                                               rect: window.wjReplay.canvasRect(), phase: document.getElementById('phase').textContent,
                                               dataPhase: window.wjReplay.frame(i).phase }), index);
      const body = bodyPixels(img, info.rect);
      const dx = body.x - info.projected[0], dy = body.y - info.projected[1];
      check(body.n > 150 && Math.hypot(dx, dy) < 30,
            `${name} ${label}: the body is drawn at (${body.x.toFixed(0)}, ${body.y.toFixed(0)}) px, the data's base projects to (${info.projected[0].toFixed(0)}, ${info.projected[1].toFixed(0)}) px (${body.n} body pixels; ${shot})`);
      check(info.phase === info.dataPhase, `${name} ${label}: the phase shown is the data's ("${info.phase}")`);
      measured[label] = { body, projected: info.projected };
    }
    const moved = [0, 1].map((k) => measured.apex.projected[k] - measured.takeoff.projected[k]);
    const seen = [measured.apex.body.x - measured.takeoff.body.x, measured.apex.body.y - measured.takeoff.body.y];
    const miss = Math.hypot(seen[0] - moved[0], seen[1] - moved[1]), span = Math.hypot(...moved);
    check(span > 30 && miss < 0.2 * span + 10,
          `${name}: from take-off to apex the body moved (${seen[0].toFixed(0)}, ${seen[1].toFixed(0)}) px on screen, the data (${moved[0].toFixed(0)}, ${moved[1].toFixed(0)}) px`);

    // Play for a moment: the frame advances.
    await page.click('#play');
    await page.waitForTimeout(600);
    await page.click('#play');
    const after = await page.evaluate(() => window.wjReplay.current);
    check(after > state.events.apex_index, `${name}: play advances the frames (apex ${state.events.apex_index} -> ${after})`);
    check(errors.length === 0, `${name}: no console errors${errors.length ? ': ' + errors.join(' | ') : ''}`);
    await page.close();
  }
} finally {
  await context.close();
  fs.rmSync(profile, { recursive: true, force: true });
}
console.log(failures.length ? `${failures.length} check(s) failed` : 'all checks passed');
process.exit(failures.length ? 1 : 0);
