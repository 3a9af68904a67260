// The page's camera math (clients/web/js/camera.js): the server's pinhole rays, the default
// framing, and the orbit / pan / zoom moves. Run: node --test clients/web/tests/
import assert from 'node:assert/strict';
import test from 'node:test';

import {
    cameraRay, checkCamera, cross, defaultCamera, dot, length, normalize, orbit, pan, pixelRay, roundCamera, scale, sub, zoom,
} from '../js/camera.js';

const tutorial = { position: [0, 0, 0], look_at: [0, 0, 1], up: [0, 1, 0], fov_y_deg: 45 };
const close = (a, b, eps = 1e-12) => a.every((x, i) => Math.abs(x - b[i]) <= eps);

test('the centre of the image is the view direction', () => {
    const r = cameraRay(tutorial, 640, 480, 320, 240);
    assert.deepEqual(r.origin, [0, 0, 0]);
    assert.deepEqual(r.direction, [0, 0, 1]);
});

test('the top-left corner: up and to the picture\'s left, which is +x (docs/rendering.md)', () => {
    const r = cameraRay(tutorial, 640, 480, 0, 0);
    const t = Math.tan((22.5 * Math.PI) / 180);
    assert.ok(close(r.direction, normalize([t * (640 / 480), t, 1])));
});

test('pixel (i, j) is cast through its centre, as a render with spp = 1 samples it', () => {
    assert.deepEqual(pixelRay(tutorial, 640, 480, 319, 239), cameraRay(tutorial, 640, 480, 319.5, 239.5));
    const d = pixelRay(tutorial, 640, 480, 320, 240).direction;
    // The tutorial's first hit for that pixel (sphere 3, t ≈ 7.2716) is the server's answer in
    // tests/browser/preview_e2e.mjs; here the ray's direction is half a pixel off the axis.
    const halfPixel = Math.tan((22.5 * Math.PI) / 180) / 480;
    assert.ok(close(d, normalize([-halfPixel, -halfPixel, 1]), 1e-15));
});

test('default framing: the bounds\' centre seen from -z, the bounding sphere filling the height', () => {
    const cam = defaultCamera({ min: [-2, -2, 6], max: [2, 5, 12] });
    const radius = 0.5 * Math.sqrt(16 + 49 + 36);
    assert.deepEqual(cam.look_at, [0, 1.5, 9]);
    assert.ok(close(cam.position, [0, 1.5, 9 - radius / Math.sin((22.5 * Math.PI) / 180)]));
    assert.deepEqual(defaultCamera({ min: [1, 1, 1], max: [0, 0, 0] }).position, [0, 0, 0]);
});

test('default framing of a tiny scene: the distance follows its size (as the server frames it)', () => {
    for (const s of [1e-300, 1e-20, 1, 1e20, 1e300]) {
        const cam = defaultCamera({ min: [-s, -s, -s], max: [s, s, s] });
        assert.ok(Math.abs(-cam.position[2] / s - Math.sqrt(3) / Math.sin(Math.PI / 8)) < 1e-12);
        // and a zoom in moves towards it rather than out to a fixed floor
        const closer = zoom(cam, 0.5);
        assert.ok(Math.abs(closer.position[2] / cam.position[2] - 0.5) < 1e-12);
    }
});

test('default framing of a model file: from +z, +x on the right of the picture, as glTF viewers show it', () => {
    const bounds = { min: [-2, -2, 6], max: [2, 5, 12] };
    const back = defaultCamera(bounds, 4 / 3, '-z');
    const front = defaultCamera(bounds, 4 / 3, '+z');
    assert.deepEqual(back, defaultCamera(bounds));
    assert.deepEqual(front.look_at, back.look_at);
    assert.ok(close(front.position, [0, 1.5, 9 + (9 - back.position[2])], 1e-12));
    // The right edge's ray leans towards +x from the front and towards -x from the back.
    assert.ok(cameraRay(front, 640, 480, 640, 240).direction[0] > 0);
    assert.ok(cameraRay(back, 640, 480, 640, 240).direction[0] < 0);
});

test('default framing of a flat model: from 45° above (or beside), not edge-on (as the server frames it)', () => {
    const ground = defaultCamera({ min: [-1, 0, -1], max: [1, 0, 1] }, 1, '+z');
    const dist = Math.sqrt(2) / Math.sin((22.5 * Math.PI) / 180);
    assert.deepEqual(ground.look_at, [0, 0, 0]);
    assert.ok(close(ground.position, [0, dist / Math.sqrt(2), dist / Math.sqrt(2)], 1e-12));
    const under = defaultCamera({ min: [-1, 0, -1], max: [1, 0, 1] }, 1, '-z');
    assert.ok(close(under.position, [0, dist / Math.sqrt(2), -dist / Math.sqrt(2)], 1e-12));
    const wall = defaultCamera({ min: [0, -1, -1], max: [0, 1, 1] }, 1, '+z');
    assert.ok(close(wall.position, [dist / Math.sqrt(2), 0, dist / Math.sqrt(2)], 1e-12));
});

test('default framing, portrait: the bounding sphere fills the width (as engine/render/render_test.cpp checks)', () => {
    const bounds = { min: [-1, 0, 2], max: [3, 1, 4] };
    const c = [1, 0.5, 3];
    const radius = 0.5 * Math.sqrt(16 + 1 + 4);
    const distance = (ray) => length(sub(sub(c, ray.origin), scale(ray.direction, dot(sub(c, ray.origin), ray.direction))));
    for (const [w, h] of [[640, 480], [480, 640], [300, 300]]) {
        const cam = defaultCamera(bounds, w / h);
        const top = distance(cameraRay(cam, w, h, w / 2, 0));
        const left = distance(cameraRay(cam, w, h, 0, h / 2));
        const [narrow, wide] = w >= h ? [top, left] : [left, top];
        assert.ok(Math.abs(narrow - radius) < 1e-12 * radius, `${w}x${h}: ${narrow} vs ${radius}`);
        assert.ok(wide >= radius * (1 - 1e-12), `${w}x${h}`);
    }
    // Landscape images frame by the height: the 4:3 default is the old framing.
    assert.deepEqual(defaultCamera(bounds, 16 / 9), defaultCamera(bounds));
});

test('orbit keeps look_at, the distance and up; a full turn comes back', () => {
    const cam = defaultCamera({ min: [-1, -1, -1], max: [1, 1, 1] });
    const d0 = length(sub(cam.position, cam.look_at));
    const moved = orbit(cam, 0.7, 0.3);
    assert.deepEqual(moved.look_at, cam.look_at);
    assert.ok(Math.abs(length(sub(moved.position, moved.look_at)) - d0) < 1e-12);
    let back = cam;
    for (let i = 0; i < 8; i++) back = orbit(back, Math.PI / 4, 0);
    assert.ok(close(back.position, cam.position, 1e-12));
});

test('dragging right turns the camera to its left; pitch rises and stops short of the pole', () => {
    const right = normalize(cross(normalize(sub(tutorial.look_at, tutorial.position)), tutorial.up));
    const moved = orbit(tutorial, -0.1, 0);
    assert.ok(dot(sub(moved.position, tutorial.position), right) < 0);
    const up = orbit(tutorial, 0, 0.2);
    assert.ok(up.position[1] > 0);
    const top = orbit(tutorial, 0, 10);
    assert.ok(checkCamera(top), 'never parallel to up');
});

test('pan moves position and look_at together, across the view', () => {
    const moved = pan(tutorial, 10, -5, 480);
    const delta = sub(moved.position, tutorial.position);
    assert.ok(close(delta, sub(moved.look_at, tutorial.look_at)));
    assert.ok(Math.abs(dot(delta, [0, 0, 1])) < 1e-15);
    // The look_at plane follows the cursor: 480 pixels is the picture's height there.
    const full = pan(tutorial, 0, 480, 480);
    assert.ok(Math.abs(full.position[1] - 2 * Math.tan((22.5 * Math.PI) / 180)) < 1e-12);
});

test('zoom scales the distance to look_at and never reaches it', () => {
    assert.ok(close(zoom(tutorial, 2).position, [0, 0, -1]));
    assert.ok(length(sub(zoom(tutorial, 0).position, tutorial.look_at)) > 0);
});

test('rounded cameras are short and usable; bad ones are refused', () => {
    const r = roundCamera({ position: [1 / 3, -0, 2], look_at: [0, 0, 1], up: [0, 1, 0], fov_y_deg: 45 });
    assert.deepEqual(r.position, [0.333333333, 0, 2]);
    assert.deepEqual(roundCamera({ ...tutorial, position: [8.3e-17, 0, -3] }).position, [0, 0, -3]);
    assert.equal(checkCamera({ position: [0, 0, 0], look_at: [0, 0, 0] }), null);
    assert.equal(checkCamera({ look_at: [0, 5, 0], up: [0, 1, 0] }), null);
    assert.equal(checkCamera({ fov_y_deg: 180 }), null);
    assert.equal(checkCamera({ position: [0, 'x', 0] }), null);
    assert.deepEqual(checkCamera({}), tutorial);
});
