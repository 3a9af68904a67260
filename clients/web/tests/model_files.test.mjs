// Dropped files → the body and Content-Type of POST /v1/scenes (clients/web/js/model_files.js).
import assert from 'node:assert/strict';
import test from 'node:test';

import { UploadError, prepareUpload } from '../js/model_files.js';

// Node has File but not FileReader: a minimal one for readAsDataURL.
globalThis.FileReader ??= class {
    readAsDataURL(file) {
        file.arrayBuffer().then((b) => {
            this.result = `data:${file.type || 'application/octet-stream'};base64,${Buffer.from(b).toString('base64')}`;
            this.onload();
        });
    }
};

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
