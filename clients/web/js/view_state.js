// The view as data: what the URL carries (docs/api.md "GET /": ?scene=…&camera=…&shading=…&spp=…),
// the render request body made from it, and the same request as a curl command.
// Pure functions (no DOM), so they are tested under Node (clients/web/tests/).

import { checkCamera } from './camera.js';

export const SHADINGS = ['phong', 'normal', 'depth', 'object_id', 'barycentric'];
export const LIGHTINGS = ['auto', 'scene', 'headlight'];
/** `auto` sends no precision: the server's default (fast for renders, refined for queries). */
export const PRECISIONS = ['auto', 'fast', 'refined', 'exact'];
export const SIZES = ['320x240', '640x480', '800x600', '1024x768', '1280x720', '1920x1080'];

export const DEFAULTS = Object.freeze({
    scene: null,
    camera: null,
    shading: 'phong',
    lighting: 'auto',
    spp: 4,
    max_depth: 5,
    precision: 'auto',
    size: '640x480',
});

const kLimits = { spp: [1, 4096], max_depth: [1, 32] };

function intIn(text, [lo, hi]) {
    if (!/^\d+$/.test(text)) return null;
    const n = Number(text);
    return n >= lo && n <= hi ? n : null;
}

/** Width and height of a "WxH" size (each in [1, 16384]), or null. */
export function parseSize(text) {
    const m = /^(\d{1,5})x(\d{1,5})$/.exec(String(text ?? ''));
    if (!m) return null;
    const w = Number(m[1]);
    const h = Number(m[2]);
    return w >= 1 && h >= 1 && w <= 16384 && h <= 16384 ? { width: w, height: h } : null;
}

/**
 * The view a query string describes. Values that cannot be used fall back to the defaults and
 * are named in `problems` (the page shows them), so a mangled link still opens.
 */
export function parseQuery(search) {
    const q = new URLSearchParams(search);
    const view = { ...DEFAULTS };
    const problems = [];
    const scene = q.get('scene');
    if (scene !== null) {
        if (/^[A-Za-z0-9_]+$/.test(scene)) view.scene = scene;
        else problems.push(`scene "${scene}" is not a scene id`);
    }
    const camera = q.get('camera');
    if (camera !== null) {
        let parsed = null;
        try {
            parsed = checkCamera(JSON.parse(camera));
        } catch {
            parsed = null;
        }
        if (parsed) view.camera = parsed;
        else problems.push('camera is not a usable camera JSON (position, look_at, up, fov_y_deg)');
    }
    const choice = (key, allowed) => {
        const v = q.get(key);
        if (v === null) return;
        if (allowed.includes(v)) view[key] = v;
        else problems.push(`${key} "${v}" is not one of ${allowed.join(', ')}`);
    };
    choice('shading', SHADINGS);
    choice('lighting', LIGHTINGS);
    choice('precision', PRECISIONS);
    for (const key of ['spp', 'max_depth']) {
        const v = q.get(key);
        if (v === null) continue;
        const n = intIn(v, kLimits[key]);
        if (n !== null) view[key] = n;
        else problems.push(`${key} "${v}" is not a whole number in [${kLimits[key].join(', ')}]`);
    }
    const size = q.get('size');
    if (size !== null) {
        if (parseSize(size)) view.size = size;
        else problems.push(`size "${size}" is not WIDTHxHEIGHT`);
    }
    return { view, problems };
}

/** The query string of a view ("?scene=…&camera=…"): the scene and camera when set, the other
 *  settings when they differ from the defaults. */
export function toQuery(view) {
    const q = new URLSearchParams();
    if (view.scene) q.set('scene', view.scene);
    if (view.camera) q.set('camera', JSON.stringify(view.camera));
    for (const key of ['shading', 'spp', 'lighting', 'max_depth', 'precision', 'size']) {
        if (view[key] !== DEFAULTS[key]) q.set(key, String(view[key]));
    }
    const s = q.toString();
    return s ? `?${s}` : '';
}

/**
 * The body of POST /v1/scenes/{id}/render for the view at `scale` of its size (1/8 and 1/2 for
 * the refining preview) with `spp` samples. `lighting` is always sent (the server's `auto`
 * is the default too; sending it keeps a copied curl command explicit); `precision` only when
 * chosen (`auto`: the server's default for renders, `fast`). Several samples are taken
 * adaptively (`"sampling": "adaptive"`: the extra ones only where a pixel's first sample shows
 * differently from a neighbour's, docs/rendering.md), which halves the final frame's rays on a
 * model with a plain background.
 */
export function renderBody(view, { scale = 1, spp = view.spp } = {}) {
    const { width, height } = parseSize(view.size) ?? parseSize(DEFAULTS.size);
    const body = {
        camera: view.camera,
        width: Math.max(1, Math.round(width * scale)),
        height: Math.max(1, Math.round(height * scale)),
        spp,
        max_depth: view.max_depth,
        shading: view.shading,
        lighting: view.lighting,
    };
    if (spp > 1) body.sampling = 'adaptive';
    if (view.precision !== 'auto') body.precision = view.precision;
    return body;
}

/** A POSIX shell word: 'text' with each ' written as '\''. */
export function shellQuote(text) {
    return `'${String(text).replace(/'/g, `'\\''`)}'`;
}

/** The render request as a curl command that writes the PNG to render.png. */
export function curlCommand(origin, sceneId, body) {
    const url = `${origin}/v1/scenes/${sceneId}/render`;
    return [
        'curl -sS --fail-with-body -X POST',
        shellQuote(url),
        "-H 'Content-Type: application/json'",
        '-d',
        shellQuote(JSON.stringify(body)),
        '-o render.png',
    ].join(' ');
}
