// End-to-end test of the preview page (issue 15) in Debian's chromium, headless, driven by
// playwright-core (never a browser download), against a real raycastd started here.
//
//   RAYCASTD_BINARY=build/release/server/raycastd node tests/browser/preview_e2e.mjs
//
// Steps, each with a screenshot in $RAYCASTD_ARTIFACTS (default build/test-artifacts/browser):
//   1. the empty page at 1280×800, no console errors
//   2. upload Duck.glb by the file input: the preview appears (decoded: non-background pixels in
//      the model's region, shaded: many colours and a spread of brightness); lighting headlight
//      and scene are taken; normal shading gives many colours
//   3. orbit by dragging: the image and the URL's camera change; a render over the pixel limit
//      shows "413 too_large"; a newer view aborts the render in flight; the keyboard orbits too
//   4. click a pixel on the model: the hit panel names the object, the tree shows I1
//   5. reload the shared URL: the same view comes back
//   6. download PNG, copy camera JSON, copy as curl (the command is run and makes a PNG);
//      Duck.gltf picked with its .bin and .png uploads as one model
//   7. the tutorial's spheres (clients/examples/tutorial-spheres.json), dropped on the page:
//      the centre pixel is sphere 3, as in the tutorial; its ray tree; and every pixel's ray,
//      computed by the page, hits the object the server's object_id render shows there
//   8. a broken GLB shows "422 model_load_failed" and the loader's message
//   9. a link to a scene the server does not have shows "404 scene_not_found"
//  10. a narrow window (420 px): no sideways scrolling
// Exit 0: passed; 77: skipped (no browser on this machine); 1: failed.

import { execFileSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const sourceDir = process.env.RAYCASTD_SOURCE_DIR ?? path.resolve(here, '../..');
const binary = process.env.RAYCASTD_BINARY ?? path.join(sourceDir, 'build/release/server/raycastd');
const sharedDir = process.env.RAYCASTD_SHARED_DIR ?? path.resolve(sourceDir, '../shared');
const models = path.join(sharedDir, 'data/models');
const artifacts = process.env.RAYCASTD_ARTIFACTS ?? path.join(sourceDir, 'build/test-artifacts/browser');
const chromiumPath = process.env.RAYCASTD_CHROMIUM ?? '/usr/bin/chromium';
const kBudgetMs = 90_000;

const t0 = Date.now();
const log = (msg) => console.log(`[${((Date.now() - t0) / 1000).toFixed(1)}s] ${msg}`);
const skip = (why) => {
    console.log(`SKIPPED: ${why}`);
    process.exit(77);
};

if (!fs.existsSync(chromiumPath))
    skip(`no browser at ${chromiumPath} (scripts/setup.sh installs Debian's chromium)`);
let chromium;
try {
    ({ chromium } = await import(path.join(here, 'node_modules/playwright-core/index.mjs')));
} catch (err) {
    console.error(`FAILED: playwright-core is not installed in ${here} (run scripts/setup.sh, or npm ci there): ${err.message}`);
    process.exit(1);
}
if (!fs.existsSync(binary)) {
    console.error(`FAILED: no raycastd at ${binary} (set RAYCASTD_BINARY)`);
    process.exit(1);
}
const haveModels = fs.existsSync(path.join(models, 'Duck/glTF-Binary/Duck.glb'));
if (!haveModels) console.log(`NOTE: models not found at ${models}: the Duck steps are skipped, the broken GLB is made here`);
fs.mkdirSync(artifacts, { recursive: true });
for (const f of fs.readdirSync(artifacts)) if (f.endsWith('.png')) fs.rmSync(path.join(artifacts, f));

// ------------------------------------------------------------------------------------------
// The server and the browser

function startServer() {
    return new Promise((resolve, reject) => {
        const proc = spawn(binary, ['--port', '0', '--threads', '8', '--demo', path.join(sourceDir, 'clients/examples/tutorial-spheres.json')], {
            stdio: ['ignore', 'pipe', 'pipe'],
        });
        let out = '';
        proc.stdout.on('data', (d) => {
            out += d;
            const m = /listening on (http:\/\/[^\s]+)/.exec(out);
            if (m) resolve({ proc, url: m[1] });
        });
        proc.stderr.on('data', (d) => process.stderr.write(`[server] ${d}`));
        proc.on('exit', (code) => reject(new Error(`raycastd exited (${code}) before listening: ${out}`)));
    });
}

const server = await startServer();
log(`raycastd at ${server.url}`);
const userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'raycastd-chromium-'));
const context = await chromium.launchPersistentContext(userDataDir, {
    executablePath: chromiumPath,
    headless: true,
    // As root chromium needs --no-sandbox; there is no GPU; background networking, component
    // updates, sync, the first-run page and QUIC would only knock on this machine's closed
    // network; --disable-dev-shm-usage copes with a container's small /dev/shm.
    args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-quic', '--disable-dev-shm-usage'],
    viewport: { width: 1280, height: 800 },
    acceptDownloads: true,
});
const cleanup = async () => {
    await context.close().catch(() => {});
    server.proc.kill('SIGKILL');
    fs.rmSync(userDataDir, { recursive: true, force: true });
};
const watchdog = setTimeout(async () => {
    console.error(`FAILED: over the ${kBudgetMs / 1000} s budget`);
    await cleanup();
    process.exit(1);
}, kBudgetMs);

const page = context.pages()[0] ?? (await context.newPage());
const consoleErrors = [];
page.on('console', (m) => {
    if (m.type() === 'error') consoleErrors.push(m.text());
});
page.on('pageerror', (e) => consoleErrors.push(`page error: ${e.message}`));
// Render requests the page cancelled (AbortController → the browser reports net::ERR_ABORTED).
let abortedRenders = 0;
page.on('requestfailed', (r) => {
    if (r.url().endsWith('/render') && /ABORT/i.test(r.failure()?.errorText ?? '')) abortedRenders += 1;
});

// ------------------------------------------------------------------------------------------
// Helpers

let failures = 0;
function check(ok, what) {
    if (ok) log(`ok   ${what}`);
    else {
        failures += 1;
        log(`FAIL ${what}`);
    }
}
let shot = 0;
async function screenshot(name) {
    shot += 1;
    const file = path.join(artifacts, `${String(shot).padStart(2, '0')}-${name}.png`);
    await page.screenshot({ path: file });
    log(`screenshot ${file}`);
}
const frames = () => page.$eval('#viewport', (v) => Number(v.dataset.frames ?? 0));
/** Waits until a full frame newer than frame number `after` is on screen. */
async function waitFull(after, timeout = 20000) {
    await page.waitForFunction(
        (n) => {
            const v = document.getElementById('viewport');
            return (v.dataset.stage === 'full' && v.dataset.state === 'idle' && Number(v.dataset.frames) > n) || v.dataset.stage === 'error';
        },
        after,
        { timeout },
    );
    const stage = await page.$eval('#viewport', (v) => v.dataset.stage);
    if (stage === 'error') throw new Error(`render failed: ${await page.textContent('#error-code')} ${await page.textContent('#error-message')}`);
}
/** Decodes the picture on screen: pixel statistics and a 32×24 grey thumbnail. */
const decode = () =>
    page.evaluate(async () => {
        const img = document.getElementById('frame');
        await img.decode();
        const w = img.naturalWidth;
        const h = img.naturalHeight;
        const c = document.createElement('canvas');
        c.width = w;
        c.height = h;
        const g = c.getContext('2d', { willReadFrequently: true });
        g.drawImage(img, 0, 0);
        const d = g.getImageData(0, 0, w, h).data;
        const bg = [d[0], d[1], d[2]];
        let fg = 0;
        let central = 0;
        let centralFg = 0;
        const colours = new Set();
        const lum = [];
        const thumb = new Array(32 * 24).fill(0);
        for (let y = 0; y < h; y++) {
            for (let x = 0; x < w; x++) {
                const i = 4 * (y * w + x);
                const isFg = Math.abs(d[i] - bg[0]) + Math.abs(d[i + 1] - bg[1]) + Math.abs(d[i + 2] - bg[2]) > 12;
                const inCentre = x > w / 4 && x < (3 * w) / 4 && y > h / 4 && y < (3 * h) / 4;
                if (isFg) {
                    fg += 1;
                    colours.add((d[i] << 16) | (d[i + 1] << 8) | d[i + 2]);
                    lum.push(0.2126 * d[i] + 0.7152 * d[i + 1] + 0.0722 * d[i + 2]);
                }
                if (inCentre) {
                    central += 1;
                    if (isFg) centralFg += 1;
                }
                thumb[Math.floor((y * 24) / h) * 32 + Math.floor((x * 32) / w)] += (d[i] + d[i + 1] + d[i + 2]) / 3;
            }
        }
        const per = (w / 32) * (h / 24);
        // The spread of the model's brightness (Rec. 709 luma, 8-bit): its 90th minus its 10th
        // percentile. A flat silhouette has ~0 (only its antialiased edge differs).
        lum.sort((a, b) => a - b);
        const pct = (q) => (lum.length ? lum[Math.min(lum.length - 1, Math.floor(q * lum.length))] : 0);
        // A pixel on the model to click: the foreground pixel nearest the foreground's centroid
        // whose 5 × 5 neighbourhood is all foreground (not on a silhouette, where a pixel's
        // centre may miss what its antialiased colour shows).
        const isFgAt = (x, y) => {
            const i = 4 * (y * w + x);
            return Math.abs(d[i] - bg[0]) + Math.abs(d[i + 1] - bg[1]) + Math.abs(d[i + 2] - bg[2]) > 12;
        };
        let sx = 0;
        let sy = 0;
        for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) if (isFgAt(x, y)) (sx += x), (sy += y);
        let fgPixel = null;
        let best = Infinity;
        for (let y = 2; y < h - 2 && fg; y++) {
            for (let x = 2; x < w - 2; x++) {
                const dist = (x - sx / fg) ** 2 + (y - sy / fg) ** 2;
                if (dist >= best) continue;
                let inside = true;
                for (let v = -2; v <= 2 && inside; v++) for (let u = -2; u <= 2 && inside; u++) inside = isFgAt(x + u, y + v);
                if (inside) (best = dist), (fgPixel = [x, y]);
            }
        }
        return {
            w, h, fg: fg / (w * h), centralFg: centralFg / central, colours: colours.size,
            lumSpread: pct(0.9) - pct(0.1), thumb: thumb.map((v) => v / per), fgPixel,
        };
    });
const thumbDiff = (a, b) => a.thumb.reduce((s, v, i) => s + Math.abs(v - b.thumb[i]), 0) / a.thumb.length;
const urlCamera = () => JSON.parse(new URL(page.url()).searchParams.get('camera') ?? 'null');
/** Clicks the centre of pixel (i, j) of the full-size frame. */
async function clickPixel(i, j, size = [640, 480]) {
    const box = await page.locator('#stage').boundingBox();
    await page.mouse.click(box.x + (box.width * (i + 0.5)) / size[0], box.y + (box.height * (j + 0.5)) / size[1]);
}
async function upload(file) {
    const before = await frames();
    await page.setInputFiles('#file-input', file);
    return before;
}

// ------------------------------------------------------------------------------------------
// The steps

try {
    await context.grantPermissions(['clipboard-read', 'clipboard-write'], { origin: server.url });
    await page.goto(`${server.url}/`);
    await page.waitForSelector('body[data-ready="true"]');
    check((await page.title()).includes('raycastd'), 'GET / serves the page');
    check((await page.locator('#scene-select option').count()) >= 2, 'the registered scenes are listed (the demo spheres)');
    await screenshot('empty');

    if (haveModels) {
        const before = await upload(path.join(models, 'Duck/glTF-Binary/Duck.glb'));
        await waitFull(before);
        const duck = await decode();
        check(duck.w === 640 && duck.h === 480, `the full frame is 640×480 (${duck.w}×${duck.h})`);
        check(duck.fg > 0.05 && duck.centralFg > 0.2, `the duck covers the middle of the picture (${(duck.fg * 100).toFixed(1)}% of all pixels, ${(duck.centralFg * 100).toFixed(1)}% of the central box)`);
        // Shaded, not a flat grey silhouette: the Duck has no lights, so lighting auto gives it
        // the headlight, and its vertex normals shade it smoothly.
        check(duck.colours > 100 && duck.lumSpread > 40, `the duck is shaded: many colours (${duck.colours}) and a spread of brightness (p90 − p10 = ${duck.lumSpread.toFixed(1)} of 255)`);
        const sceneId = new URL(page.url()).searchParams.get('scene');
        check(/^sc_/.test(sceneId ?? '') && urlCamera() !== null, `the URL names the scene and camera (${sceneId})`);
        check((await page.textContent('#scene-info')).includes('4,212') || (await page.textContent('#scene-info')).includes('4212'), 'the scene panel shows its 4212 triangles');
        await screenshot('duck-phong');

        // Each lighting is taken by the server (no error, no fallback): headlight looks like
        // auto here (the Duck has no lights), scene is the flat ambient-only silhouette.
        let n = await frames();
        await page.selectOption('#settings select[name=lighting]', 'headlight');
        await waitFull(n);
        const head = await decode();
        check(!(await page.isVisible('#error')) && thumbDiff(head, duck) < 1, `lighting=headlight is taken and looks like auto (thumbnail difference ${thumbDiff(head, duck).toFixed(2)})`);
        check(new URL(page.url()).searchParams.get('lighting') === 'headlight', 'the URL carries lighting=headlight');
        n = await frames();
        await page.selectOption('#settings select[name=lighting]', 'scene');
        await waitFull(n);
        const flat = await decode();
        check(!(await page.isVisible('#error')) && flat.lumSpread < duck.lumSpread, `lighting=scene is taken: ambient only, flatter (spread ${flat.lumSpread.toFixed(1)})`);
        await screenshot('duck-scene-lighting');
        n = await frames();
        await page.selectOption('#settings select[name=lighting]', 'auto');
        await waitFull(n);

        n = await frames();
        await page.selectOption('#settings select[name=shading]', 'normal');
        await waitFull(n);
        const normal = await decode();
        check(normal.colours > 50, `normal shading gives many colours (${normal.colours})`);
        check(new URL(page.url()).searchParams.get('shading') === 'normal', 'the URL carries shading=normal');
        await screenshot('duck-normal');

        // Orbit: a drag to the right turns the duck.
        const camBefore = urlCamera();
        n = await frames();
        const box = await page.locator('#stage').boundingBox();
        const cx = box.x + box.width / 2;
        const cy = box.y + box.height / 2;
        await page.mouse.move(cx, cy);
        await page.mouse.down();
        await page.mouse.move(cx + 160, cy + 30, { steps: 16 });
        await page.mouse.up();
        await waitFull(n);
        log(`     (${await page.$eval('#viewport', (v) => v.dataset.aborted)} stale passes ended, ${abortedRenders} render requests aborted in flight)`);
        await page.waitForFunction((c) => new URL(location.href).searchParams.get('camera') !== c, JSON.stringify(camBefore));
        const orbited = await decode();
        const camAfter = urlCamera();
        check(JSON.stringify(camAfter.position) !== JSON.stringify(camBefore.position), `the URL's camera moved (${JSON.stringify(camBefore.position)} → ${JSON.stringify(camAfter.position)})`);
        check(JSON.stringify(camAfter.look_at) === JSON.stringify(camBefore.look_at), 'orbiting keeps look_at');
        check(thumbDiff(normal, orbited) > 2, `the picture changed (mean thumbnail difference ${thumbDiff(normal, orbited).toFixed(1)} grey levels)`);
        await screenshot('duck-orbited');

        // A render the server refuses is on the page with its code, over the dimmed last frame.
        const spp = page.locator('#settings input[name=spp]');
        await spp.fill('64');
        await spp.dispatchEvent('change');
        await page.waitForSelector('#error:not([hidden])');
        const tooLarge = await page.textContent('#error-code');
        check(tooLarge === '413 too_large' && (await page.isVisible('#frame.stale')), `640×480 at spp 64 shows ${tooLarge} over the dimmed last frame`);
        await screenshot('render-refused');

        // A newer view cancels the request in flight: ask for spp 32, and change back to 4
        // while that full frame is being rendered. The spp-32 request is held here until the
        // page has moved on, so that it is in flight however fast the machine renders it.
        const abortedBefore = abortedRenders;
        let release;
        const released = new Promise((resolve) => (release = resolve));
        const hold = async (route) => {
            if (route.request().postDataJSON()?.spp === 32) await released;
            await route.continue().catch(() => {}); // aborted meanwhile: nothing to continue
        };
        await page.route('**/render', hold);
        await spp.fill('32');
        await spp.dispatchEvent('change');
        await page.waitForFunction(() => document.getElementById('viewport').dataset.state === 'rendering full');
        n = await frames();
        await spp.fill('4');
        await spp.dispatchEvent('change');
        await waitFull(n);
        for (let i = 0; i < 40 && abortedRenders === abortedBefore; i++) await page.waitForTimeout(50);
        release();
        await page.unroute('**/render', hold);
        check(abortedRenders > abortedBefore, `the stale spp-32 render was aborted in flight (${abortedRenders - abortedBefore} request(s) net::ERR_ABORTED)`);
        check(!(await page.isVisible('#error')), 'the next good frame clears the render error');

        n = await frames();
        await page.focus('#viewport');
        await page.keyboard.press('ArrowLeft');
        await waitFull(n);
        check(JSON.stringify(urlCamera()) !== JSON.stringify(camAfter), 'the arrow keys orbit too');

        // A pixel on the model (the Duck is seen through its file's camera, off the centre).
        const onModel = (await decode()).fgPixel;
        check(onModel !== null, `the frame has a pixel well inside the model (${onModel})`);
        await clickPixel(...(onModel ?? [320, 240]));
        await page.waitForSelector('#hit[data-state]:not([data-state="casting"])');
        const hitName = await page.textContent('#hit .hit-name').catch(() => null);
        check(hitName === 'LOD3spShape', `the hit panel names the duck's mesh (${hitName})`);
        check((await page.locator('#tree g.node[data-label="I1"]').count()) === 1, 'the ray tree shows I1');
        await screenshot('duck-hit');

        // The URL is the view: reloading it shows the same camera and settings.
        const shared = page.url();
        n = 0;
        await page.goto(shared);
        await page.waitForSelector('body[data-ready="true"]');
        await waitFull(n);
        check(page.url() === shared, 'reloading the shared URL keeps it');
        check((await page.inputValue('#settings select[name=shading]')) === 'normal', 'the reloaded page has the shared shading');

        // Download, copy camera, copy as curl.
        const [download] = await Promise.all([page.waitForEvent('download'), page.click('#download')]);
        const pngFile = path.join(artifacts, 'download.png');
        await download.saveAs(pngFile);
        check(fs.readFileSync(pngFile).subarray(1, 4).toString() === 'PNG' && download.suggestedFilename().endsWith('.png'), `download PNG gives a PNG (${download.suggestedFilename()})`);
        await page.click('#copy-camera');
        const copied = await page.evaluate(() => navigator.clipboard.readText());
        check(copied === JSON.stringify(urlCamera()), 'copy camera JSON copies the URL camera');
        await page.click('#copy-curl');
        const curl = await page.evaluate(() => navigator.clipboard.readText());
        check(curl.includes(`/v1/scenes/${sceneId}/render`), 'copy as curl names the render route');
        const curlDir = fs.mkdtempSync(path.join(os.tmpdir(), 'raycastd-curl-'));
        execFileSync('sh', ['-c', curl], { cwd: curlDir, timeout: 20000 });
        const curlPng = fs.readFileSync(path.join(curlDir, 'render.png'));
        check(curlPng.subarray(1, 4).toString() === 'PNG', `the copied curl command renders a PNG (${curlPng.length} bytes)`);
        fs.rmSync(curlDir, { recursive: true, force: true });
    }

    // A .gltf with its .bin and texture picked together: the page embeds them.
    if (haveModels) {
        const dir = path.join(models, 'Duck/glTF');
        const before = await upload(['Duck.gltf', 'Duck0.bin', 'DuckCM.png'].map((f) => path.join(dir, f)));
        await waitFull(before);
        const info = await page.textContent('#scene-info');
        check(info.includes('Duck.gltf') && info.includes('4212'), 'Duck.gltf with Duck0.bin and DuckCM.png uploads as one model');
    }

    // An .obj picked with its .mtl and JPEG textures: they travel in its inline mesh's files,
    // and the spider comes out textured, seen from the front of its file (+z).
    if (haveModels) {
        const dir = path.join(models, 'spider');
        const picked = ['spider.obj', 'spider.mtl', 'SpiderTex.jpg', 'drkwood2.jpg', 'engineflare1.jpg', 'wal67ar_small.jpg', 'wal69ar_small.jpg'];
        const before = await upload(picked.map((f) => path.join(dir, f)));
        await waitFull(before);
        const info = await page.textContent('#scene-info');
        check(info.includes('1368') && info.includes('✓ textures'), `spider.obj with its .mtl and JPEGs uploads as one textured model (${info.includes('✓ textures') ? 'textures' : 'no textures'})`);
        const frame = await decode();
        check(frame.fg > 0.03 && frame.colours > 100, `and renders (${(frame.fg * 100).toFixed(1)}% of the pixels, ${frame.colours} colours)`);
        await screenshot('spider-textured');
    }

    // A model file without a camera opens from its front, +z (a glTF asset's front faces +z),
    // as the server frames it (the summary's default_view), its bounds' centre in the middle.
    {
        const off = path.join(os.tmpdir(), `raycastd-front-${process.pid}.off`);
        fs.writeFileSync(off, 'OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n');
        const before = await upload(off);
        await waitFull(before);
        fs.rmSync(off, { force: true });
        const cam = urlCamera();
        check(
            JSON.stringify(cam.look_at) === '[0.5,0.5,0.5]' && cam.position[0] === 0.5 && cam.position[1] === 0.5 && cam.position[2] > 2,
            `a model file without a camera is seen from +z (${JSON.stringify(cam)})`,
        );
        const frame = await decode();
        check(frame.fg > 0.05 && frame.centralFg > 0.2, `and fills the middle of the picture (${(frame.fg * 100).toFixed(1)}% of all pixels)`);
        await screenshot('model-from-the-front');
    }

    // The tutorial's spheres: the eye at the origin looking along +z; the centre pixel's ray
    // is (almost) the tutorial's ray, and the first sphere it hits is sphere 3.
    {
        await page.selectOption('#settings select[name=shading]', 'phong');
        // This time by dropping the file on the page.
        const before = await frames();
        const spheres = fs.readFileSync(path.join(sourceDir, 'clients/examples/tutorial-spheres.json'), 'utf8');
        const dataTransfer = await page.evaluateHandle((text) => {
            const dt = new DataTransfer();
            dt.items.add(new File([text], 'tutorial-spheres.json', { type: 'application/json' }));
            return dt;
        }, spheres);
        await page.dispatchEvent('#viewport', 'dragenter', { dataTransfer });
        check(await page.isVisible('#drop'), 'dragging a file over the page shows the drop target');
        await page.dispatchEvent('#viewport', 'drop', { dataTransfer });
        await waitFull(before);
        check(!(await page.isVisible('#drop')), 'dropping it uploads it');
        const cam = urlCamera();
        check(JSON.stringify(cam.position) === '[0,0,0]' && JSON.stringify(cam.look_at) === '[0,0,1]', `the document's camera frames the view (${JSON.stringify(cam)})`);
        await clickPixel(320, 240);
        await page.waitForSelector('#hit[data-state]:not([data-state="casting"])');
        const name = await page.textContent('#hit .hit-name').catch(() => null);
        check(name === 'sphere 3', `the centre pixel hits sphere 3 (${name})`);
        const t = await page.$eval('#hit dd[title]', (dd) => Number(dd.title)).catch(() => NaN);
        check(Math.abs(t - 7.27) < 0.01, `its t is the tutorial's 7.27 (${t})`);
        check((await page.locator('#tree g.node[data-label="I1"]').getAttribute('aria-label'))?.includes('sphere 3'), 'the ray tree shows I1 on sphere 3');
        // The page's pixel rays are the server's: every pixel of an object_id render at spp 1
        // has the colour of the object that the page's ray for that pixel hits (intersect).
        const agreement = await page.evaluate(async () => {
            const { pixelRay } = await import('./web/js/camera.js');
            const q = new URL(location.href).searchParams;
            const scene = q.get('scene');
            const camera = JSON.parse(q.get('camera'));
            const [W, H] = [160, 120];
            const post = (route, body) =>
                fetch(`v1/scenes/${scene}/${route}`, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
            const png = await (await post('render', { camera, width: W, height: H, spp: 1, shading: 'object_id' })).blob();
            const bitmap = await createImageBitmap(png);
            const c = new OffscreenCanvas(W, H).getContext('2d');
            c.drawImage(bitmap, 0, 0);
            const d = c.getImageData(0, 0, W, H).data;
            const rays = [];
            for (let j = 0; j < H; j++) for (let i = 0; i < W; i++) rays.push(pixelRay(camera, W, H, i, j));
            const { hits } = await (await post('intersect', { rays, precision: 'fast', fields: ['object'] })).json();
            const colourOf = new Map();
            let mismatches = 0;
            hits.forEach((h, k) => {
                const rgb = (d[4 * k] << 16) | (d[4 * k + 1] << 8) | d[4 * k + 2];
                const key = h.hit ? h.object : 'miss';
                if (!colourOf.has(key)) colourOf.set(key, rgb);
                if (colourOf.get(key) !== rgb) mismatches += 1;
            });
            return { pixels: hits.length, objects: colourOf.size, mismatches };
        });
        check(agreement.objects === 4 && agreement.mismatches === 0, `the page's pixel rays hit what the server's render shows (${agreement.pixels} pixels, ${agreement.objects - 1} spheres and the background, ${agreement.mismatches} disagree)`);
        await screenshot('spheres-hit');
    }

    // A broken model: the server's 422 and the loader's message are on the page.
    {
        let broken = path.join(models, 'invalid/gltf-validator/base/data/glb/truncated_chunk_data.glb');
        if (!haveModels || !fs.existsSync(broken)) {
            // A GLB header that declares more bytes than follow.
            broken = path.join(os.tmpdir(), `raycastd-broken-${process.pid}.glb`);
            const b = Buffer.alloc(20);
            b.write('glTF', 0);
            b.writeUInt32LE(2, 4);
            b.writeUInt32LE(64, 8);
            fs.writeFileSync(broken, b);
        }
        await upload(broken);
        await page.waitForSelector('#error:not([hidden])');
        const code = await page.textContent('#error-code');
        const message = await page.textContent('#error-message');
        check(code === '422 model_load_failed', `a broken GLB shows its error code (${code})`);
        check(/GLB/i.test(message) && message.includes(path.basename(broken)), `and the loader's message (${message})`);
        await screenshot('broken-glb');
    }

    // A link to a scene the server does not have.
    {
        await page.goto(`${server.url}/?scene=sc_0000000000000000`);
        await page.waitForSelector('body[data-ready="true"]');
        const code = await page.textContent('#error-code');
        check(code === '404 scene_not_found' && (await page.isVisible('#error')), `a stale scene id shows ${code}`);
    }

    // A narrow window: everything is reachable without sideways scrolling.
    {
        await page.setViewportSize({ width: 420, height: 860 });
        await page.waitForTimeout(300);
        const overflow = await page.evaluate(() => document.documentElement.scrollWidth - window.innerWidth);
        check(overflow <= 1, `no sideways scrolling at 420 px (${overflow} px over)`);
        await screenshot('narrow');
    }

    // The only console errors allowed are the 413 of the refused render, the 422 of the broken
    // upload and the 404 of the stale link (the browser logs failed requests).
    const unexpected = consoleErrors.filter((e) => !/status of (413|422|404)/.test(e));
    check(unexpected.length === 0, `no unexpected console errors${unexpected.length ? `: ${unexpected.join(' | ')}` : ''}`);
} catch (err) {
    failures += 1;
    log(`FAIL ${err.stack ?? err}`);
    await screenshot('failure').catch(() => {});
}

clearTimeout(watchdog);
await cleanup();
log(failures ? `${failures} check(s) FAILED` : 'all checks passed');
process.exit(failures ? 1 : 0);
