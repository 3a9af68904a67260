// Dropped files → the body and Content-Type of POST /v1/scenes (clients/web/js/model_files.js).
import assert from 'node:assert/strict';
import test from 'node:test';

import { UploadError, mtlTextures, prepareUpload } from '../js/model_files.js';

// Node has File but not FileReader: a minimal one for readAsDataURL.
globalThis.FileReader ??= class {
    readAsDataURL(file) {
        file.arrayBuffer().then((b) => {
            this.result = `data:${file.type || 'application/octet-stream'};base64,${Buffer.from(b).toString('base64')}`;
            this.onload();
        });
    }
};

// The eight bytes a PNG starts with: what the page checks before it sends an image along.
const kPngSignature = new Uint8Array([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]);

const gltf = (uri) => JSON.stringify({ asset: { version: '2.0' }, buffers: [{ uri, byteLength: 3 }], images: [{ uri: 'tex%20one.png' }] });

test('model files go as their own content types', async () => {
    const cases = { 'a.glb': 'model/gltf-binary', 'a.OBJ': 'model/obj', 'a.stl': 'application/sla', 'a.ply': 'application/x-ply', 'a.off': 'model/off', 'a.xyz': 'application/octet-stream' };
    for (const [name, type] of Object.entries(cases)) {
        const u = await prepareUpload([new File(['x'], name)]);
        assert.equal(u.contentType, type, name);
        assert.equal(u.name, name);
    }
});

test('a scene document keeps its parsed form (its camera frames the view)', async () => {
    const doc = { objects: [{ type: 'sphere', center: [0, 0, 10], radius: 2 }], camera: { position: [0, 0, 0] } };
    const u = await prepareUpload([new File([JSON.stringify(doc)], 'scene.json')]);
    assert.equal(u.contentType, 'application/json');
    assert.deepEqual(u.document, doc);
});

test('a .gltf takes its dropped companions along as data: URIs', async () => {
    const u = await prepareUpload([
        new File([new Uint8Array([1, 2, 3])], 'Duck0.bin'),
        new File([gltf('Duck0.bin')], 'Duck.gltf'),
        new File([new Uint8Array([9])], 'tex one.png'),
    ]);
    assert.equal(u.name, 'Duck.gltf');
    assert.equal(u.contentType, 'model/gltf+json');
    const doc = JSON.parse(u.body);
    assert.equal(doc.buffers[0].uri, 'data:application/octet-stream;base64,AQID');
    assert.equal(doc.images[0].uri, 'data:image/png;base64,CQ==');
});

test('a .gltf whose files were not dropped is refused before anything is sent', async () => {
    await assert.rejects(prepareUpload([new File([gltf('Duck0.bin')], 'Duck.gltf')]), (err) => {
        assert.ok(err instanceof UploadError);
        assert.match(err.message, /Duck0\.bin, tex%20one\.png/);
        return true;
    });
});

test('JSON that does not parse goes to the server, which names the byte (bad_json)', async () => {
    const u = await prepareUpload([new File(['{"objects": ['], 'broken.json')]);
    assert.equal(u.contentType, 'application/json');
});

test('an .obj takes its dropped .mtl and textures along in an inline mesh\'s files', async () => {
    const obj = 'mtllib sub/spider.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n';
    const mtl = 'newmtl skin\nmap_Kd -s 1 1 1 -clamp on .\\tex\\Skin.jpg\nmap_Kd other.png\n';
    const u = await prepareUpload([
        new File([mtl], 'spider.mtl'),
        new File([obj], 'spider.obj'),
        new File([new Uint8Array([255, 216, 255])], 'Skin.jpg'),
    ]);
    assert.equal(u.name, 'spider.obj');
    assert.equal(u.contentType, 'application/json');
    const mesh = JSON.parse(u.body).objects[0];
    assert.deepEqual(Object.keys(mesh), ['type', 'name', 'format', 'data_base64', 'files']);
    assert.equal(mesh.name, 'spider');
    assert.equal(Buffer.from(mesh.data_base64, 'base64').toString(), obj);
    // Keyed as the model names them: the texture relative to the library's folder; the
    // texture that was not dropped (other.png) is left for the server's warning.
    assert.deepEqual(Object.keys(mesh.files).sort(), ['sub/spider.mtl', 'sub/tex/Skin.jpg']);
    assert.equal(Buffer.from(mesh.files['sub/spider.mtl'], 'base64').toString(), mtl);
    assert.deepEqual([...Buffer.from(mesh.files['sub/tex/Skin.jpg'], 'base64')], [255, 216, 255]);
    // Alone, or with nothing it names, it goes as it is.
    for (const files of [[new File([obj], 'a.obj')], [new File([obj], 'a.obj'), new File(['x'], 'b.mtl')]]) {
        const alone = await prepareUpload(files);
        assert.equal(alone.contentType, 'model/obj');
    }
});

test('map_Kd options are skipped as the server skips them', () => {
    assert.deepEqual(mtlTextures('map_Kd -o 0.5 0.5 -mm 0 1 -bm 2 a b.png\nmap_Kd -zz c.png\n'), ['a b.png', '-zz c.png']);
    // An infinite number is not one, nor one out of range (the name starts there); "+-1" is
    // one; a '#' is part of the name (no comment in map_Kd); a no-break space is not a blank.
    assert.deepEqual(
        mtlTextures('map_Kd -s 1 1 inf a.png\nmap_Kd -s 1e-400 b.png\nmap_Kd -s +-1 1 1 c.png\nmap_Kd tex#1.png\nmap_Kd a\u00a0b.png\n'),
        ['inf a.png', '1e-400 b.png', 'c.png', 'tex#1.png', 'a\u00a0b.png'],
    );
});

test('an .obj\'s names are read as the server reads them, and each file goes once', async () => {
    // A continued mtllib statement with a comment; two libraries in sibling folders that name
    // one texture (one key, normalised); a TGA the server cannot decode is left out.
    const obj = 'mtllib \\\n m1/a.mtl m2/b.mtl # libraries\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n';
    const u = await prepareUpload([
        new File([obj], 'x.obj'),
        new File(['newmtl a\nmap_Kd ../tex/red.png\n'], 'a.mtl'),
        new File(['newmtl b\nmap_Kd ../tex/red.png\nmap_Kd c.tga\n'], 'b.mtl'),
        new File([kPngSignature], 'red.png'),
        new File([new Uint8Array([0, 0, 2])], 'c.tga'),
    ]);
    const mesh = JSON.parse(u.body).objects[0];
    assert.deepEqual(Object.keys(mesh.files).sort(), ['m1/a.mtl', 'm2/b.mtl', 'tex/red.png']);
});

test('an .obj\'s whole mtllib argument comes before its words, and names are used as written', async () => {
    const obj = 'mtllib my lib.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n';
    const u = await prepareUpload([
        new File([obj], 'x.obj'),
        new File(['newmtl a\nmap_Kd a%20b.png\n'], 'my lib.mtl'),
        new File(['newmtl b\n'], 'lib.mtl'),
        new File([kPngSignature], 'a%20b.png'),
    ]);
    const mesh = JSON.parse(u.body).objects[0];
    assert.deepEqual(Object.keys(mesh.files).sort(), ['a%20b.png', 'my lib.mtl']);
});
