// The preview page (docs/api.md "GET /"): pick or upload a scene, orbit it, watch the preview refine,
// click a pixel to see its hit and ray tree. State lives in `view` (what the URL carries) and
// in `scene` (the registered scene's summary); the server does all the rendering.

import * as api from './api.js';
import { checkCamera, defaultCamera, pixelRay, roundCamera } from './camera.js';
import { attachControls } from './controls.js';
import { h } from './dom.js';
import { prepareUpload } from './model_files.js';
import { renderHit, renderSceneInfo } from './panels.js';
import { Preview } from './preview.js';
import { renderRayTree } from './ray_tree.js';
import * as vs from './view_state.js';

const $ = (id) => document.getElementById(id);
const ui = {
    viewport: $('viewport'),
    stage: $('stage'),
    frame: $('frame'),
    marker: $('marker'),
    badge: $('badge'),
    empty: $('empty'),
    frameInfo: $('frame-info'),
    settings: $('settings'),
    sceneSelect: $('scene-select'),
    sceneInfo: $('scene-info'),
    hit: $('hit'),
    tree: $('tree'),
    error: $('error'),
    errorCode: $('error-code'),
    errorMessage: $('error-message'),
    toast: $('toast'),
    drop: $('drop'),
    fileInput: $('file-input'),
    serverInfo: $('server-info'),
};

/** Names and cameras of scenes this browser uploaded: the summary carries no name, and no camera
 *  when the server predates the summary's `camera`. */
const memory = {
    read(key) {
        try {
            return JSON.parse(localStorage.getItem(`raycastd.${key}`) ?? '{}');
        } catch {
            return {};
        }
    },
    remember(key, id, value) {
        const all = this.read(key);
        all[id] = value;
        try {
            localStorage.setItem(`raycastd.${key}`, JSON.stringify(all));
        } catch {
            // Private windows may refuse storage: the page works without it.
        }
    },
};

let view = { ...vs.DEFAULTS };
let scene = null; // {summary, label, home (camera)}
let shown = null; // {url, view, stage}
let lastFull = null; // {blob, view}
let pick = null; // {pixel, controller}
let errorSource = null;

const size = () => vs.parseSize(view.size);
const queryPrecision = () => (view.precision === 'auto' ? undefined : view.precision);

// ---------------------------------------------------------------------------------------------
// Messages

function showError(err, source) {
    console.warn(`raycastd page: ${source}:`, err);
    const label = err.label ?? err.name ?? 'error';
    ui.errorCode.textContent = label;
    ui.errorMessage.textContent = `${err.message}${err.path ? ` (at ${err.path})` : ''}`;
    ui.error.hidden = false;
    ui.error.dataset.code = err.code ?? '';
    ui.error.dataset.source = source;
    errorSource = source;
}

function clearError(source) {
    if (source === undefined || source === errorSource) {
        ui.error.hidden = true;
        errorSource = null;
    }
}

let toastTimer = 0;
function toast(text) {
    ui.toast.textContent = text;
    ui.toast.classList.add('show');
    clearTimeout(toastTimer);
    toastTimer = setTimeout(() => ui.toast.classList.remove('show'), 2600);
}

// ---------------------------------------------------------------------------------------------
// The URL

let urlTimer = 0;
function saveUrl(now = false) {
    clearTimeout(urlTimer);
    const write = () => history.replaceState(null, '', `${location.pathname}${vs.toQuery(view)}`);
    if (now) write();
    else urlTimer = setTimeout(write, 200);
}

// ---------------------------------------------------------------------------------------------
// The picture

function fitStage() {
    const { width, height } = size();
    const box = ui.viewport.getBoundingClientRect();
    const k = Math.min(box.width / width, box.height / height);
    ui.stage.style.width = `${Math.max(1, Math.floor(width * k))}px`;
    ui.stage.style.height = `${Math.max(1, Math.floor(height * k))}px`;
    placeMarker();
}

function placeMarker() {
    if (!pick?.pixel) {
        ui.marker.hidden = true;
        return;
    }
    const { width, height } = size();
    const [i, j] = pick.pixel;
    ui.marker.style.left = `${((i + 0.5) / width) * 100}%`;
    ui.marker.style.top = `${((j + 0.5) / height) * 100}%`;
    ui.marker.hidden = false;
}

const preview = new Preview({
    render: (v, stage, signal) =>
        api.render(v.scene, vs.renderBody(v, { scale: stage.scale, spp: stage.fullSpp ? v.spp : 1 }), signal),
    onFrame: (frame) => {
        const url = URL.createObjectURL(frame.blob);
        const old = shown?.url;
        ui.frame.src = url;
        ui.frame.classList.remove('stale');
        ui.frame.hidden = false;
        if (old) ui.frame.addEventListener('load', () => URL.revokeObjectURL(old), { once: true });
        shown = { url, view: frame.view, stage: frame.stage };
        if (frame.stage === 'full') lastFull = { blob: frame.blob, view: frame.view };
        const body = vs.renderBody(frame.view, {
            scale: frame.stage === '1/8' ? 1 / 8 : frame.stage === '1/2' ? 1 / 2 : 1,
            spp: frame.stage === 'full' ? frame.view.spp : 1,
        });
        ui.badge.textContent = frame.stage === 'full' ? '' : `preview ${frame.stage}`;
        ui.badge.hidden = frame.stage === 'full';
        ui.frameInfo.textContent =
            `${body.width}×${body.height}, spp ${body.spp}${body.sampling ? ` ${body.sampling}` : ''} · ` +
            `${frame.renderMs.toFixed(1)} ms render, ` +
            `${frame.roundTripMs.toFixed(0)} ms round trip · ${frame.precision} · ${frame.rays}`;
        ui.viewport.dataset.stage = frame.stage;
        ui.viewport.dataset.frames = String(preview.stats.frames);
        ui.viewport.dataset.aborted = String(preview.stats.aborted);
        clearError('render');
    },
    onError: (err) => {
        ui.frame.classList.add('stale');
        ui.badge.textContent = 'render failed';
        ui.badge.hidden = false;
        ui.viewport.dataset.stage = 'error';
        showError(err, 'render');
    },
    onState: (state) => {
        ui.viewport.dataset.state = state;
        ui.viewport.setAttribute('aria-busy', String(state.startsWith('rendering')));
    },
});

function refresh({ moving = false } = {}) {
    if (!scene) return;
    saveUrl();
    preview.update({ ...view }, { moving });
}

function setCamera(camera, moving) {
    view.camera = roundCamera(camera);
    refresh({ moving });
}

// ---------------------------------------------------------------------------------------------
// Scenes

function optionLabel(s) {
    const names = memory.read('names');
    const parts = [];
    if (s.triangles) parts.push(`${s.triangles.toLocaleString('en')} triangles`);
    if (s.spheres) parts.push(`${s.spheres} sphere${s.spheres > 1 ? 's' : ''}`);
    return `${names[s.id] ?? s.id} — ${parts.join(', ') || `${s.objects} objects`}`;
}

async function loadSceneList() {
    try {
        const scenes = await api.listScenes();
        const keep = scene?.summary.id ?? '';
        ui.sceneSelect.replaceChildren(
            h('option', { value: '' }, scenes.length ? '— choose a registered scene —' : '— no scenes registered yet —'),
            ...scenes.map((s) => h('option', { value: s.id }, optionLabel(s))),
        );
        ui.sceneSelect.value = scenes.some((s) => s.id === keep) ? keep : '';
    } catch (err) {
        showError(err, 'list');
    }
}

/** Shows scene `id`; `camera` (from the URL) wins over the scene's own framing. */
async function openScene(id, { camera = null, label = null } = {}) {
    preview.cancel();
    let summary;
    try {
        summary = await api.getScene(id);
    } catch (err) {
        showError(err, 'scene');
        return false;
    }
    clearError('scene');
    // The scene's camera: the summary's (its document's or its file's), else the document's
    // that this browser uploaded (to a server older than the summary's camera), else the
    // server's default framing of the bounds for the chosen image size (the sphere fills its
    // narrower side), from the side the summary names.
    const size = vs.parseSize(view.size) ?? vs.parseSize(vs.DEFAULTS.size);
    const home =
        checkCamera(summary.camera) ??
        checkCamera(memory.read('cameras')[id]) ??
        defaultCamera(summary.bounds, size.width / size.height, summary.default_view);
    scene = { summary, label: label ?? memory.read('names')[id] ?? null, home: roundCamera(home) };
    view.scene = id;
    view.camera = roundCamera(camera ?? home);
    lastFull = null;
    pick = null;
    placeMarker();
    ui.hit.replaceChildren(h('p', { class: 'muted' }, 'Click a pixel of the picture to cast its ray.'));
    ui.tree.replaceChildren();
    renderSceneInfo(ui.sceneInfo, summary, scene.label);
    if (![...ui.sceneSelect.options].some((o) => o.value === id))
        ui.sceneSelect.append(h('option', { value: id }, optionLabel(summary)));
    ui.sceneSelect.value = id;
    ui.empty.hidden = true;
    ui.stage.hidden = false;
    for (const b of ['reset-camera', 'download', 'copy-camera', 'copy-curl']) $(b).disabled = false;
    document.title = `${scene.label ?? id} — raycastd preview`;
    fitStage();
    saveUrl(true);
    refresh();
    return true;
}

async function upload(files) {
    let prepared;
    try {
        prepared = await prepareUpload(files);
    } catch (err) {
        showError(err, 'upload');
        return;
    }
    toast(`Uploading ${prepared.name}…`);
    ui.viewport.dataset.state = 'uploading';
    let summary;
    try {
        summary = await api.registerScene(prepared.body, prepared.contentType);
    } catch (err) {
        ui.viewport.dataset.state = 'upload failed';
        ui.toast.classList.remove('show');
        err.message = `${prepared.name}: ${err.message}`;
        showError(err, 'upload');
        return;
    }
    clearError('upload');
    memory.remember('names', summary.id, prepared.name);
    const docCamera = checkCamera(prepared.document?.camera);
    if (docCamera) memory.remember('cameras', summary.id, docCamera);
    toast(`${prepared.name}: ${summary.created ? 'registered' : 'already registered'} as ${summary.id}`);
    await loadSceneList();
    await openScene(summary.id, { label: prepared.name });
}

// ---------------------------------------------------------------------------------------------
// Picking a pixel

async function pickPixel(i, j) {
    if (!scene) return;
    const { width, height } = size();
    const ray = pixelRay(view.camera, width, height, i, j);
    pick?.controller.abort();
    const controller = new AbortController();
    pick = { pixel: [i, j], controller };
    placeMarker();
    ui.hit.replaceChildren(h('p', { class: 'muted' }, `Casting the ray through pixel (${i}, ${j})…`));
    ui.tree.replaceChildren();
    ui.hit.dataset.state = 'casting';
    const id = view.scene;
    try {
        const [answer, tree] = await Promise.all([
            api.intersect(id, ray, queryPrecision(), controller.signal),
            api.trace(id, ray, view.max_depth, queryPrecision(), controller.signal),
        ]);
        renderHit(ui.hit, { pixel: [i, j], size: { width, height }, ray, answer });
        renderRayTree(ui.tree, tree);
        ui.hit.dataset.state = answer.hit?.hit ? 'hit' : 'miss';
        clearError('pick');
        ui.hit.closest('section')?.scrollIntoView({ block: 'nearest', behavior: 'smooth' });
    } catch (err) {
        if (api.isAbort(err)) return;
        ui.hit.dataset.state = 'error';
        ui.hit.replaceChildren(h('p', { class: 'error-text' }, `${err.label ?? 'error'}: ${err.message}`));
        showError(err, 'pick');
    }
}

function pickAt(clientX, clientY) {
    const r = ui.stage.getBoundingClientRect();
    const { width, height } = size();
    const fx = (clientX - r.left) / r.width;
    const fy = (clientY - r.top) / r.height;
    if (fx < 0 || fx >= 1 || fy < 0 || fy >= 1) return;
    pickPixel(Math.min(width - 1, Math.floor(fx * width)), Math.min(height - 1, Math.floor(fy * height)));
}

// ---------------------------------------------------------------------------------------------
// Settings form

function fillSelect(name, values, labels = {}) {
    ui.settings.elements[name].replaceChildren(...values.map((v) => h('option', { value: v }, labels[v] ?? v)));
}

function writeForm() {
    const f = ui.settings.elements;
    for (const key of ['shading', 'lighting', 'precision', 'size', 'spp', 'max_depth']) f[key].value = String(view[key]);
}

function readForm() {
    const f = ui.settings.elements;
    const int = (el, lo, hi, fallback) => {
        const n = Math.round(Number(el.value));
        return Number.isFinite(n) && el.value !== '' ? Math.min(hi, Math.max(lo, n)) : fallback;
    };
    const before = view.size;
    view = {
        ...view,
        shading: f.shading.value,
        lighting: f.lighting.value,
        precision: f.precision.value,
        size: f.size.value,
        spp: int(f.spp, 1, 4096, view.spp),
        max_depth: int(f.max_depth, 1, 32, view.max_depth),
    };
    if (view.size !== before) {
        pick = null;
        fitStage();
    }
}

// ---------------------------------------------------------------------------------------------
// Buttons

async function copyText(text, what) {
    try {
        await navigator.clipboard.writeText(text);
        toast(`${what} copied`);
        return;
    } catch {
        // Not a secure context, or no permission: fall back to a selection copy.
    }
    const area = h('textarea', { class: 'copy-buffer', readonly: true });
    area.value = text;
    document.body.append(area);
    area.select();
    const ok = document.execCommand?.('copy');
    area.remove();
    if (ok) toast(`${what} copied`);
    else window.prompt(`Copy the ${what}:`, text);
}

const base = () => new URL('.', document.baseURI).href.replace(/\/$/, '');

async function downloadPng() {
    if (!scene) return;
    let blob = lastFull && vs.toQuery(lastFull.view) === vs.toQuery(view) ? lastFull.blob : null;
    if (!blob) {
        try {
            toast('Rendering the full frame…');
            blob = (await api.render(view.scene, vs.renderBody(view))).blob;
        } catch (err) {
            showError(err, 'download');
            return;
        }
    }
    const url = URL.createObjectURL(blob);
    const a = h('a', { href: url, download: `raycastd-${(scene.label ?? view.scene).replace(/[^\w.-]+/g, '_')}-${view.shading}.png` });
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
}

// ---------------------------------------------------------------------------------------------
// Start

function wire() {
    fillSelect('shading', vs.SHADINGS);
    fillSelect('lighting', vs.LIGHTINGS);
    fillSelect('precision', vs.PRECISIONS, { auto: 'auto' });
    fillSelect('size', vs.SIZES, Object.fromEntries(vs.SIZES.map((s) => [s, s.replace('x', '×')])));
    writeForm();
    ui.settings.addEventListener('change', () => {
        readForm();
        refresh();
    });
    ui.settings.addEventListener('submit', (e) => e.preventDefault());

    ui.sceneSelect.addEventListener('change', () => {
        if (ui.sceneSelect.value) openScene(ui.sceneSelect.value);
    });
    $('refresh-scenes').addEventListener('click', loadSceneList);
    for (const b of ['open-file', 'open-file-2']) $(b).addEventListener('click', () => ui.fileInput.click());
    ui.fileInput.addEventListener('change', () => {
        if (ui.fileInput.files.length) upload(ui.fileInput.files);
        ui.fileInput.value = '';
    });
    $('error-close').addEventListener('click', () => clearError());
    $('reset-camera').addEventListener('click', () => scene && setCamera(scene.home, false));
    $('download').addEventListener('click', downloadPng);
    $('copy-camera').addEventListener('click', () => scene && copyText(JSON.stringify(view.camera), 'camera JSON'));
    $('copy-curl').addEventListener('click', () => scene && copyText(vs.curlCommand(base(), view.scene, vs.renderBody(view)), 'curl command'));

    attachControls(ui.viewport, {
        camera: () => (scene ? view.camera : null),
        change: setCamera,
        release: () => preview.release(),
        pick: pickAt,
        pickCentre: () => {
            const { width, height } = size();
            pickPixel(Math.floor(width / 2), Math.floor(height / 2));
        },
        reset: () => scene && setCamera(scene.home, false),
        viewHeight: () => ui.stage.getBoundingClientRect().height || size().height,
    });
    new ResizeObserver(fitStage).observe(ui.viewport);
    ui.frame.addEventListener('error', () => {
        if (ui.frame.getAttribute('src')) showError(new Error('the rendered image could not be decoded'), 'render');
    });

    // Dropping files anywhere on the page uploads them.
    let depth = 0;
    const hasFiles = (e) => [...(e.dataTransfer?.types ?? [])].includes('Files');
    document.addEventListener('dragenter', (e) => {
        if (!hasFiles(e)) return;
        depth += 1;
        ui.drop.hidden = false;
    });
    document.addEventListener('dragleave', () => {
        depth = Math.max(0, depth - 1);
        if (!depth) ui.drop.hidden = true;
    });
    document.addEventListener('dragover', (e) => {
        if (hasFiles(e)) e.preventDefault();
    });
    document.addEventListener('drop', (e) => {
        if (!hasFiles(e)) return;
        e.preventDefault();
        depth = 0;
        ui.drop.hidden = true;
        upload(e.dataTransfer.files);
    });
}

async function main() {
    wire();
    const { view: fromUrl, problems } = vs.parseQuery(location.search);
    view = { ...fromUrl };
    writeForm();
    fitStage();
    renderSceneInfo(ui.sceneInfo, null);
    if (problems.length) showError({ label: 'link', message: `ignored: ${problems.join('; ')}` }, 'link');
    fetch('v1/info')
        .then((r) => (r.ok ? r.json() : null))
        .then((info) => {
            if (info) ui.serverInfo.textContent = `raycastd ${info.version} · Embree ${info.embree_version}`;
        })
        .catch(() => {});
    await loadSceneList();
    if (view.scene) await openScene(view.scene, { camera: fromUrl.camera });
    document.body.dataset.ready = 'true';
}

main();
