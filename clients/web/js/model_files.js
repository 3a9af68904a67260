// Files a person drops on the page → the body and Content-Type of POST /v1/scenes (API.md:
// model/gltf-binary, model/gltf+json with embedded buffers, model/obj, application/sla,
// application/x-ply, model/off, or a scene document as application/json).
//
// A .gltf that refers to external files (Duck.gltf → Duck0.bin, DuckCM.png) can be dropped
// together with them: the page embeds them as data: URIs, since a raw glTF body must be
// self-contained. A reference that was not dropped is named before anything is sent. An .obj
// dropped with its .mtl and textures goes as a scene document whose inline mesh carries them
// in `files`.

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

// map_Kd options and how many arguments each takes (engine/load/obj_reader.cpp's table); -o, -s
// and -t take up to three numbers.
const kMapOptionArity = {
    '-blendu': 1, '-blendv': 1, '-boost': 1, '-mm': 2, '-texres': 1,
    '-clamp': 1, '-bm': 1, '-imfchan': 1, '-cc': 1, '-type': 1,
};

/** A file name as an OBJ or MTL writes it, as the server reads it: '\\' → '/', no leading './'. */
const objName = (name) => {
    let s = name.trim().replaceAll('\\', '/');
    while (s.startsWith('./')) s = s.slice(2);
    return s;
};

/** The map_Kd names of an MTL (the maps the server samples), as the server parses them. */
export function mtlTextures(text) {
    const out = [];
    for (const line of text.split(/\r?\n/)) {
        const t = line.trim().split(/\s+/);
        if (t.length < 2 || t[0] !== 'map_Kd') continue;
        let i = 1;
        while (i < t.length && t[i].length > 1 && t[i][0] === '-') {
            const opt = t[i];
            if (opt === '-o' || opt === '-s' || opt === '-t') {
                i += 1;
                for (let k = 0; k < 3 && i < t.length && Number.isFinite(Number(t[i])); k++) i += 1;
                continue;
            }
            if (!(opt in kMapOptionArity)) break; // not an option: part of the file name
            i += 1 + kMapOptionArity[opt];
        }
        const name = objName(t.slice(i).join(' '));
        if (name) out.push(name);
    }
    return out;
}

/** The mtllib names of an OBJ: the whole argument, and each word when there are several. */
function mtlLibraries(text) {
    const out = [];
    for (const line of text.split(/\r?\n/)) {
        const t = line.trim().split(/\s+/);
        if (t.length < 2 || t[0] !== 'mtllib') continue;
        out.push(objName(line.trim().slice('mtllib'.length)));
        if (t.length > 2) out.push(...t.slice(1).map(objName));
    }
    return out;
}

const base64Of = async (file) => (await dataUri(file, 'application/octet-stream')).replace(/^data:[^,]*,/, '');

/** An OBJ dropped with its .mtl and textures: a scene document of one inline mesh object that
 *  carries them in `files` (docs/api.md), keyed by the names the OBJ and MTL give them; the page
 *  finds each by its base name among the dropped files. Null when none of them was dropped (the
 *  OBJ then goes as it is; the server warns about a library it cannot read). */
async function objDocument(main, companions) {
    const lookup = new Map(companions.map((f) => [f.name.toLowerCase(), f]));
    const files = {};
    for (const lib of mtlLibraries(await main.text())) {
        const mtl = lookup.get(baseName(lib));
        if (!mtl || lib in files) continue;
        files[lib] = await base64Of(mtl);
        const dir = lib.includes('/') ? lib.slice(0, lib.lastIndexOf('/') + 1) : '';
        for (const tex of mtlTextures(await mtl.text())) {
            const image = lookup.get(baseName(tex));
            if (image) files[dir + tex] = await base64Of(image);
        }
    }
    if (!Object.keys(files).length) return null;
    const stem = main.name.replace(/\.[^.]*$/, '');
    return { objects: [{ type: 'mesh', name: stem, format: 'obj', data_base64: await base64Of(main), files }] };
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
    if (ext === 'obj' && companions.length) {
        const doc = await objDocument(main, companions);
        if (doc) return { ...upload, contentType: CONTENT_TYPES.json, body: JSON.stringify(doc) };
    }
    return upload;
}
