// The refining preview (clients/web/js/preview.js): 1/8, 1/2, full; a newer view aborts the
// older view's request; nothing larger than 1/8 starts while the camera moves.
import assert from 'node:assert/strict';
import test from 'node:test';

import { Preview } from '../js/preview.js';

globalThis.requestAnimationFrame ??= (f) => setTimeout(f, 0);
const wait = (ms) => new Promise((r) => setTimeout(r, ms));
/** Waits until `cond()` holds (a loaded CI machine runs timers late), at most `ms`. */
async function until(cond, ms = 5000) {
    for (const end = Date.now() + ms; !cond() && Date.now() < end; ) await wait(5);
}

/**
 * A fake server: each render takes `ms` (or `ms(view)`; Infinity: until aborted) unless
 * aborted; records what happened.
 */
function fakeRender(ms = 25) {
    const log = [];
    const render = (view, stage, signal) =>
        new Promise((resolve, reject) => {
            const entry = { view: view.id, stage: stage.name, aborted: false };
            log.push(entry);
            const delay = typeof ms === 'function' ? ms(view) : ms;
            const t = delay === Infinity ? undefined : setTimeout(() => resolve({ stage: stage.name }), delay);
            signal.addEventListener('abort', () => {
                clearTimeout(t);
                entry.aborted = true;
                reject(new DOMException('aborted', 'AbortError'));
            });
        });
    return { render, log };
}

function preview(render, frames, errors = []) {
    return new Preview({ render, onFrame: (f) => frames.push(`${f.view.id}:${f.stage}`), onError: (e) => errors.push(e), settleMs: 20 });
}

test('a still view refines 1/8 → 1/2 → full', async () => {
    const { render } = fakeRender(5);
    const frames = [];
    const p = preview(render, frames);
    p.update({ id: 'a' });
    await until(() => frames.length >= 3);
    assert.deepEqual(frames, ['a:1/8', 'a:1/2', 'a:full']);
});

test('a newer view aborts the request the older one has in flight', async () => {
    // The older view's render never ends on its own, so the newer view always finds it in flight
    // (a fixed 40 ms render ended first on a loaded CI machine).
    const { render, log } = fakeRender((view) => (view.id === 'a' ? Infinity : 5));
    const frames = [];
    const p = preview(render, frames);
    p.update({ id: 'a' });
    await until(() => log.length >= 1);
    p.update({ id: 'b' });
    await until(() => frames.length >= 3);
    assert.deepEqual(log[0], { view: 'a', stage: '1/8', aborted: true });
    assert.ok(frames.every((f) => f.startsWith('b:')), frames.join());
    assert.deepEqual(frames, ['b:1/8', 'b:1/2', 'b:full']);
    assert.equal(p.stats.aborted, 1);
});

test('while the camera moves only 1/8 frames come; release lets the pass finish', async () => {
    const { render } = fakeRender(5);
    const frames = [];
    const p = preview(render, frames);
    p.update({ id: 'a' }, { moving: true });
    await wait(120);
    assert.deepEqual(frames, ['a:1/8']);
    p.release();
    await until(() => frames.length >= 3);
    assert.deepEqual(frames, ['a:1/8', 'a:1/2', 'a:full']);
});

test('a failed render is reported once and the pass stops', async () => {
    const errors = [];
    const frames = [];
    const p = preview(() => Promise.reject(Object.assign(new Error('boom'), { code: 'internal' })), frames, errors);
    p.update({ id: 'a' });
    await until(() => errors.length >= 1);
    await wait(50);
    assert.equal(errors.length, 1);
    assert.deepEqual(frames, []);
});
