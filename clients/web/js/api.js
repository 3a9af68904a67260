// The HTTP API as the page uses it (API.md). Every failure becomes an ApiError carrying the
// HTTP status and the API's machine code, so the page can always say what went wrong
// ("422 model_load_failed: model: truncated GLB …") instead of showing a blank image.
// Paths are relative ("v1/…"), so the page also works behind a proxy that mounts it under a
// sub-path.

export class ApiError extends Error {
    /**
     * @param {number} status  HTTP status (0: no answer at all)
     * @param {string} code    the API's code ("model_load_failed"), or "network" / "http_<status>"
     * @param {string} message the server's message
     * @param {string} [path]  JSON pointer into the request, when the server named one
     */
    constructor(status, code, message, path = '') {
        super(message);
        this.name = 'ApiError';
        this.status = status;
        this.code = code;
        this.path = path;
    }

    /** "422 model_load_failed" */
    get label() {
        return this.status ? `${this.status} ${this.code}` : this.code;
    }
}

/** True for the rejection of a fetch that an AbortController cancelled. */
export function isAbort(err) {
    return err?.name === 'AbortError';
}

async function errorFrom(res) {
    const text = await res.text().catch(() => '');
    try {
        const e = JSON.parse(text).error;
        if (e && typeof e.code === 'string')
            return new ApiError(res.status, e.code, String(e.message ?? ''), e.path ?? '');
    } catch {
        // Not the API's JSON (a proxy's page, say): show what came back.
    }
    const snippet = text.replace(/\s+/g, ' ').trim().slice(0, 200);
    return new ApiError(res.status, `http_${res.status}`, snippet || res.statusText || 'error');
}

async function send(method, path, { body, contentType, signal } = {}) {
    let res;
    try {
        res = await fetch(path, {
            method,
            body,
            signal,
            headers: contentType ? { 'Content-Type': contentType } : {},
            cache: 'no-store',
        });
    } catch (err) {
        if (isAbort(err)) throw err;
        throw new ApiError(0, 'network', `cannot reach raycastd (${err.message})`);
    }
    if (!res.ok) throw await errorFrom(res);
    return res;
}

const json = (method, path, body, signal) =>
    send(method, path, {
        body: body === undefined ? undefined : JSON.stringify(body),
        contentType: body === undefined ? undefined : 'application/json',
        signal,
    }).then((r) => r.json());

/** GET /v1/scenes → the scene summaries. */
export const listScenes = (signal) => json('GET', 'v1/scenes', undefined, signal).then((r) => r.scenes);

/** GET /v1/scenes/{id} → its summary (404 scene_not_found). */
export const getScene = (id, signal) => json('GET', `v1/scenes/${encodeURIComponent(id)}`, undefined, signal);

/** POST /v1/scenes with a scene document or model file body → the summary, plus
 *  `created` (201) or not (200: the same bytes were registered before). */
export async function registerScene(body, contentType) {
    const res = await send('POST', 'v1/scenes', { body, contentType });
    return { ...(await res.json()), created: res.status === 201 };
}

/** POST /v1/scenes/{id}/render → the PNG and what the headers say about it. */
export async function render(id, body, signal) {
    const t0 = performance.now();
    const res = await send('POST', `v1/scenes/${encodeURIComponent(id)}/render`, {
        body: JSON.stringify(body),
        contentType: 'application/json',
        signal,
    });
    const blob = await res.blob();
    return {
        blob,
        renderMs: Number(res.headers.get('X-Render-Ms')),
        rays: res.headers.get('X-Rays') ?? '',
        precision: res.headers.get('X-Precision') ?? '',
        roundTripMs: performance.now() - t0,
    };
}

/** POST /v1/scenes/{id}/intersect with one ray → {precision, hit}. */
export async function intersect(id, ray, precision, signal) {
    const body = { rays: [ray], mode: 'closest' };
    if (precision) body.precision = precision;
    const r = await json('POST', `v1/scenes/${encodeURIComponent(id)}/intersect`, body, signal);
    return { precision: r.precision, hit: r.hits[0] };
}

/** POST /v1/scenes/{id}/trace → the Whitted ray tree of one ray. */
export function trace(id, ray, maxDepth, precision, signal) {
    const body = { ray, max_depth: maxDepth };
    if (precision) body.precision = precision;
    return json('POST', `v1/scenes/${encodeURIComponent(id)}/trace`, body, signal);
}
