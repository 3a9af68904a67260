// The refining preview. Every change of the view starts a new pass: a 1/8-size frame at once,
// then — once the camera has been still for `settleMs` — a 1/2-size frame, then the full frame
// with the chosen spp (the progressive display of <model-viewer> and the glTF Sample Viewer,
// done by the server). Starting a pass aborts the request of the pass before it
// (AbortController): the browser drops the connection and an old frame can never replace a
// newer one. (raycastd 0.1.0 still finishes a render whose client has gone; once it notices
// the closed connection, the abort also saves the server the work.)

import { isAbort } from './api.js';

/** The stages of one pass: size factor, and whether the view's spp is used (else 1). */
export const STAGES = [
    { name: '1/8', scale: 1 / 8, fullSpp: false },
    { name: '1/2', scale: 1 / 2, fullSpp: false },
    { name: 'full', scale: 1, fullSpp: true },
];

const sleep = (ms, signal) =>
    new Promise((resolve, reject) => {
        const t = setTimeout(resolve, ms);
        signal.addEventListener('abort', () => {
            clearTimeout(t);
            reject(new DOMException('aborted', 'AbortError'));
        });
    });

export class Preview {
    /**
     * @param {object} o
     * @param {(view, stage, signal) => Promise<object>} o.render renders one stage of a view
     * @param {(frame) => void} o.onFrame a frame arrived (frame.stage, frame.view, result fields)
     * @param {(err, view) => void} o.onError a render failed (not: was cancelled)
     * @param {(state) => void} [o.onState] 'rendering <stage>' / 'idle' / 'cancelled', for the UI
     * @param {number} [o.settleMs] stillness before the larger stages start
     */
    constructor({ render, onFrame, onError, onState = () => {}, settleMs = 180 }) {
        Object.assign(this, { render, onFrame, onError, onState, settleMs });
        this.controller = null;
        this.lastChange = 0;
        this.moving = false;
        this.pending = null;
        this.stats = { started: 0, aborted: 0, frames: 0 };
    }

    /** The view changed (`moving`: the user is still dragging). Passes start at most once per
     *  animation frame; the latest view wins. */
    update(view, { moving = false } = {}) {
        this.lastChange = performance.now();
        this.moving = moving;
        const first = this.pending === null;
        this.pending = view;
        if (first) requestAnimationFrame(() => this.start());
    }

    /** The drag ended: the larger stages may start once the view has settled. */
    release() {
        this.moving = false;
        this.lastChange = performance.now();
    }

    /** Aborts whatever is in flight (e.g. the scene is being replaced). */
    cancel() {
        if (this.controller) {
            this.controller.abort();
            this.controller = null;
        }
    }

    start() {
        const view = this.pending;
        this.pending = null;
        if (this.controller) {
            this.controller.abort();
            this.stats.aborted += 1;
        }
        const controller = new AbortController();
        this.controller = controller;
        this.run(view, controller).catch((err) => {
            if (isAbort(err)) return;
            if (this.controller === controller) this.controller = null;
            this.onState('failed');
            this.onError(err, view);
        });
    }

    async waitUntilSettled(signal) {
        for (;;) {
            const quiet = performance.now() - this.lastChange;
            if (!this.moving && quiet >= this.settleMs) return;
            await sleep(Math.max(this.settleMs - quiet, 30), signal);
        }
    }

    async run(view, controller) {
        const { signal } = controller;
        for (const [i, stage] of STAGES.entries()) {
            if (i > 0) await this.waitUntilSettled(signal);
            this.onState(`rendering ${stage.name}`);
            this.stats.started += 1;
            const result = await this.render(view, stage, signal);
            if (signal.aborted) return;
            this.stats.frames += 1;
            this.onFrame({ ...result, stage: stage.name, view });
        }
        if (this.controller === controller) this.controller = null;
        this.onState('idle');
    }
}
