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

// How the server reads an OBJ and its MTL (engine/load/obj_reader.cpp), so that the page sends
// exactly the files the server will ask for: lines end at \r, \n or \r\n; in an OBJ a backslash
// at the end of a line joins the next one (with a space); '#' starts a comment, except in a
// map_Kd line, whose file name may hold one; words are separated by ASCII blanks only. map_Kd
// options take a fixed number of arguments, except -o, -s and -t, which take up to three
// numbers (as parse_double reads them: one leading '+' dropped, then std::from_chars, which
// refuses a value out of range; and finite).
const kMapOptionArity = {
    '-blendu': 1, '-blendv': 1, '-boost': 1, '-mm': 2, '-texres': 1,
    '-clamp': 1, '-bm': 1, '-imfchan': 1, '-cc': 1, '-type': 1,
};
const kDecimal = /^-?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/;

function isNumber(token) {
    const t = token.startsWith('+') ? token.slice(1) : token;
    if (!kDecimal.test(t)) return false;
    const v = Number(t);
    const underflow = v === 0 && /[1-9]/.test(t.split(/[eE]/)[0]);
    return Number.isFinite(v) && !underflow;
}

function statements(text, continued) {
    const lines = text.split(/\r\n|\r|\n/);
    if (!continued) return lines;
    const out = [];
    for (let i = 0; i < lines.length; ) {
        const line = lines[i++];
        if (!line.endsWith('\\')) {
            out.push(line);
            continue;
        }
        const parts = [line.slice(0, -1)];
        while (i < lines.length) {
            const more = lines[i++];
            parts.push(more.endsWith('\\') ? more.slice(0, -1) : more);
            if (!more.endsWith('\\')) break;
        }
        out.push(parts.join(' '));
    }
    return out;
}

const tokens = (line, comments = true) => (comments ? line.split('#')[0] : line).split(/[ \t\v\f]+/).filter(Boolean);
const trimBlanks = (s) => s.replace(/^[ \t\v\f]+|[ \t\v\f]+$/g, '');

/** The map_Kd names of an MTL (the maps the server samples), relative to the MTL. */
export function mtlTextures(text) {
    const out = [];
    for (const line of statements(text, false)) {
        if (tokens(line)[0] !== 'map_Kd') continue;
        const t = tokens(line, false);
        if (t.length < 2) continue;
        let i = 1;
        while (i < t.length && t[i].length > 1 && t[i][0] === '-') {
            const opt = t[i];
            if (opt === '-o' || opt === '-s' || opt === '-t') {
                i += 1;
                for (let k = 0; k < 3 && i < t.length && isNumber(t[i]); k++) i += 1;
                continue;
            }
            if (!(opt in kMapOptionArity)) break; // not an option: part of the file name
            i += 1 + kMapOptionArity[opt];
        }
        let name = t.slice(i).join(' ').replaceAll('\\', '/');
        while (name.startsWith('./')) name = name.slice(2);
        if (name) out.push(name);
    }
    return out;
}

/** The mtllib names of an OBJ, one list per statement: the whole argument, then each word when
 *  there are several (the server takes the whole argument if it reads, else each word). */
function mtlLibraries(text) {
    const out = [];
    for (const line of statements(text, true)) {
        const t = tokens(line);
        if (t.length < 2 || t[0] !== 'mtllib') continue;
        const rest = trimBlanks(line.slice(line.indexOf('mtllib') + 'mtllib'.length).split('#')[0]);
        out.push([rest, ...(t.length > 2 ? t.slice(1) : [])].map((n) => {
            const s = n.replaceAll('\\', '/');
            return s.startsWith('./') ? s.slice(2) : s;
        }));
    }
    return out;
}

/** A name relative to the model normalised as the server normalises a path ("a/./b/../c" is
 *  "a/c"); null when the server would refuse it (absolute, a scheme or drive, climbing out). */
function normalizedName(name) {
    if (!name || name.startsWith('/') || /^[A-Za-z][A-Za-z0-9+.-]*:/.test(name)) return null;
    const parts = [];
    for (const p of name.split('/')) {
        if (p === '' || p === '.') continue;
        if (p === '..') {
            if (!parts.length) return null;
            parts.pop();
        } else parts.push(p);
    }
    return parts.length ? parts.join('/') : null;
}

/** The base name of a path an OBJ or MTL gives (used as written: no URI decoding). */
const plainBaseName = (name) => name.split('/').pop().toLowerCase();

const base64Of = async (file) => (await dataUri(file, 'application/octet-stream')).replace(/^data:[^,]*,/, '');

/** Whether a file starts as a PNG or a JPEG does: the images the server decodes. */
async function isPngOrJpeg(file) {
    const b = new Uint8Array(await file.slice(0, 8).arrayBuffer());
    const png = [0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a].every((v, k) => b[k] === v);
    return png || (b[0] === 0xff && b[1] === 0xd8 && b[2] === 0xff);
}

/** An OBJ dropped with its .mtl and textures: a scene document of one inline mesh object that
 *  carries them in `files` (docs/api.md), keyed by the names the OBJ and MTL give them,
 *  normalised; the page finds each by its base name among the dropped files. Null when none
 *  of them was dropped (the OBJ then goes as it is; the server warns about a library it cannot
 *  read). Images other than PNG and JPEG are left out: the server cannot decode them. */
async function objDocument(main, companions) {
    const lookup = new Map(companions.map((f) => [f.name.toLowerCase(), f]));
    const files = {};
    for (const names of mtlLibraries(await main.text())) {
        // The server takes the whole argument when it reads, else each word that does. Dropped
        // files have no folders, so a base name alone cannot tell "m1/a.mtl m2/b.mtl" (b.mtl in
        // a folder "m1/a.mtl m2") from two libraries: when the whole argument's base name is
        // its last word's, the words are taken; otherwise the whole argument comes first.
        const found = names.map((n) => [n, lookup.get(plainBaseName(n))]).filter(([n, f]) => f && normalizedName(n));
        const ambiguous = names.length > 1 && plainBaseName(names[0]) === plainBaseName(names[names.length - 1]);
        const whole = found.filter(([n]) => n === names[0]);
        const words = found.filter(([n]) => names.length > 1 && n !== names[0]);
        const chosen = whole.length && !ambiguous ? whole : words.length ? words : whole;
        for (const [lib, mtl] of chosen) {
            files[normalizedName(lib)] = await base64Of(mtl);
            const dir = lib.includes('/') ? lib.slice(0, lib.lastIndexOf('/') + 1) : '';
            for (const tex of mtlTextures(await mtl.text())) {
                const key = normalizedName(dir + tex);
                const image = lookup.get(plainBaseName(tex));
                if (key && image && !(key in files) && (await isPngOrJpeg(image))) files[key] = await base64Of(image);
            }
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
