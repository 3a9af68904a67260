// The URL form of a view and the render request made from it (clients/web/js/view_state.js).
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import test from 'node:test';

import { DEFAULTS, curlCommand, parseQuery, renderBody, shellQuote, toQuery } from '../js/view_state.js';

const camera = { position: [0, 0, 0], look_at: [0, 0, 1], up: [0, 1, 0], fov_y_deg: 45 };

test('a view survives the URL', () => {
    const view = { ...DEFAULTS, scene: 'sc_abc', camera, shading: 'normal', spp: 16, size: '320x240' };
    const q = toQuery(view);
    assert.match(q, /^\?scene=sc_abc&camera=/);
    assert.deepEqual(parseQuery(q), { view, problems: [] });
});

test('defaults stay out of the URL', () => {
    assert.equal(toQuery({ ...DEFAULTS }), '');
    assert.equal(toQuery({ ...DEFAULTS, scene: 'sc_1' }), '?scene=sc_1');
});

test('unusable values fall back to the defaults and are named', () => {
    const { view, problems } = parseQuery('?scene=../x&camera={bad&shading=toon&spp=0&max_depth=99&size=big&lighting=sun');
    assert.deepEqual(view, { ...DEFAULTS });
    assert.equal(problems.length, 7);
});

test('the render body: sizes scaled for the preview; lighting always, precision only when chosen', () => {
    const view = { ...DEFAULTS, scene: 'sc_1', camera };
    assert.deepEqual(renderBody(view), { camera, width: 640, height: 480, spp: 4, sampling: 'adaptive', max_depth: 5, shading: 'phong', lighting: 'auto' });
    const eighth = renderBody(view, { scale: 1 / 8, spp: 1 });
    assert.equal(eighth.width, 80);
    assert.equal(eighth.height, 60);
    assert.equal(eighth.spp, 1);
    assert.equal(eighth.sampling, undefined);  // one sample: nothing to adapt
    const chosen = renderBody({ ...view, lighting: 'headlight', precision: 'exact' });
    assert.equal(chosen.lighting, 'headlight');
    assert.equal(chosen.precision, 'exact');
});

test('the curl command is one shell word per argument, whatever the JSON holds', () => {
    assert.equal(shellQuote("it's"), `'it'\\''s'`);
    const cmd = curlCommand('http://127.0.0.1:8080', 'sc_1', { note: "it's" });
    // The shell reads the body back exactly.
    const echoed = execFileSync('sh', ['-c', `printf %s ${shellQuote(JSON.stringify({ note: "it's" }))}`]).toString();
    assert.equal(echoed, '{"note":"it\'s"}');
    assert.match(cmd, /^curl -sS --fail-with-body -X POST 'http:\/\/127\.0\.0\.1:8080\/v1\/scenes\/sc_1\/render'/);
});
