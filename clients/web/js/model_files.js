// Files a person drops on the page → the body and Content-Type of POST /v1/scenes (API.md:
// model/gltf-binary, model/gltf+json with embedded buffers, model/obj, application/sla,
// application/x-ply, model/off, or a scene document as application/json).
//
// A .gltf that refers to external files (Duck.gltf → Duck0.bin, DuckCM.png) can be dropped
// together with them: the page embeds them as data: URIs, since a raw glTF body must be
// self-contained. A reference that was not dropped is named before anything is sent.

export const CONTENT_TYPES = {
    glb: 'model/gltf-binary',
    gltf: 'model/gltf+json',
    obj: 'model/obj',
    stl: 'application/sla',
    ply: 'application/x-ply',
    off: 'model/off',
    json: 'application/json',
};

/** Which of several dropped files is the model, best first. */
const kMainOrder = ['gltf', 'glb', 'json', 'obj', 'ply', 'stl', 'off'];

const kImageTypes = { png: 'image/png', jpg: 'image/jpeg', jpeg: 'image/jpeg', webp: 'image/webp' };

export const extensionOf = (name) => {
    const dot = name.lastIndexOf('.');
    return dot < 0 ? '' : name.slice(dot + 1).toLowerCase();
};

const baseName = (uri) => {
    let s = uri.split(/[?#]/)[0];
    try {
        s = decodeURIComponent(s);
    } catch {
        // keep it as written
    }
    return s.split(/[\\/]/).pop().toLowerCase();
};

/** A page-side problem with the dropped files (nothing was sent). */
export class UploadError extends Error {
    constructor(message) {
        super(message);
        this.name = 'UploadError';
        this.code = 'upload';
        this.label = 'cannot upload';
    }
}

function dataUri(file, mime) {
    return new Promise((resolve, reject) => {
        const r = new FileReader();
        r.onload = () => resolve(String(r.result).replace(/^data:[^;,]*/, `data:${mime}`));
        r.onerror = () => reject(new UploadError(`cannot read ${file.name}`));
        r.readAsDataURL(file);
    });
}

async function parseJson(file) {
    try {
        return JSON.parse(await file.text());
    } catch (err) {
        return { notJson: err.message };
    }
}

/** Embeds the buffers and images of a glTF document that name companion files. */
async function embedGltf(doc, companions, name) {
    const lookup = new Map(companions.map((f) => [f.name.toLowerCase(), f]));
    const missing = [];
    const embed = async (item, mime) => {
        if (!item || typeof item.uri !== 'string' || item.uri.startsWith('data:')) return;
        const file = lookup.get(baseName(item.uri));
        if (!file) {
            missing.push(item.uri);
            return;
        }
        item.uri = await dataUri(file, mime ?? kImageTypes[extensionOf(file.name)] ?? 'application/octet-stream');
    };
    for (const b of doc.buffers ?? []) await embed(b, 'application/octet-stream');
    for (const im of doc.images ?? []) await embed(im, null);
    if (missing.length) {
        throw new UploadError(
            `${name} refers to ${missing.join(', ')}: drop ${missing.length > 1 ? 'them' : 'it'} ` +
                `together with ${name} (or use the .glb)`,
        );
    }
}

/**
 * The upload for a list of dropped or picked files: {name, contentType, body, document}, where
 * `document` is the parsed scene document (its camera frames the view) when one was dropped.
 * Files of unknown type go as application/octet-stream, and the server tells by their bytes.
 */
export async function prepareUpload(fileList) {
    const files = [...fileList];
    if (!files.length) throw new UploadError('no file');
    const rank = (f) => {
        const i = kMainOrder.indexOf(extensionOf(f.name));
        return i < 0 ? kMainOrder.length : i;
    };
    const main = [...files].sort((a, b) => rank(a) - rank(b))[0];
    const companions = files.filter((f) => f !== main);
    const ext = extensionOf(main.name);
    const upload = { name: main.name, contentType: CONTENT_TYPES[ext] ?? 'application/octet-stream', body: main, document: null };
    if (ext === 'gltf' || ext === 'json') {
        const doc = await parseJson(main);
        if (doc.notJson) {
            // Let the server say what is wrong with it (bad_json with the byte offset).
            return upload;
        }
        const isGltf = doc && typeof doc === 'object' && 'asset' in doc && !('objects' in doc);
        if (isGltf) {
            await embedGltf(doc, companions, main.name);
            return { ...upload, contentType: CONTENT_TYPES.gltf, body: JSON.stringify(doc) };
        }
        return { ...upload, contentType: CONTENT_TYPES.json, document: doc };
    }
    return upload;
}
