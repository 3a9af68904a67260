// Camera controls on the preview, as in the glTF Sample Viewer and <model-viewer>: drag to
// orbit, shift-drag or right-drag to pan, wheel to zoom; a click that does not move is a pixel
// pick. The keyboard does the same from the focused viewport: arrows orbit, Shift+arrows pan,
// + and − zoom, R (or Home) resets, Enter picks the centre pixel.

import { orbit, pan, zoom } from './camera.js';

/** Radians of orbit per CSS pixel dragged (a 500-pixel drag turns about 230°). */
const kOrbitPerPixel = 0.008;
/** A press that moves less than this (CSS pixels) is a click, not a drag. */
const kClickSlop = 4;
const kKeyOrbit = (5 * Math.PI) / 180;
const kKeyPan = 24;
const kKeyZoom = 1.15;

/**
 * @param {HTMLElement} el the element that takes the pointer and keys
 * @param {object} o
 * @param {() => object|null} o.camera the camera now (null: no scene, controls idle)
 * @param {(camera, moving: boolean) => void} o.change a new camera
 * @param {() => void} o.release a drag ended
 * @param {(x: number, y: number) => void} o.pick a click at client coordinates
 * @param {() => void} o.pickCentre Enter on the viewport
 * @param {() => void} o.reset R / Home
 * @param {() => number} o.viewHeight the picture's height on screen, CSS pixels
 */
export function attachControls(el, o) {
    let drag = null;

    el.addEventListener('contextmenu', (e) => e.preventDefault());

    el.addEventListener('pointerdown', (e) => {
        if (!o.camera() || drag) return;
        if (e.button !== 0 && e.button !== 2) return;
        el.setPointerCapture(e.pointerId);
        drag = {
            id: e.pointerId,
            mode: e.button === 2 || e.shiftKey ? 'pan' : 'orbit',
            button: e.button,
            x0: e.clientX,
            y0: e.clientY,
            x: e.clientX,
            y: e.clientY,
            moved: false,
            camera: o.camera(),
        };
        el.classList.add(drag.mode === 'pan' ? 'panning' : 'orbiting');
    });

    el.addEventListener('pointermove', (e) => {
        if (!drag || e.pointerId !== drag.id) return;
        const dx = e.clientX - drag.x;
        const dy = e.clientY - drag.y;
        drag.x = e.clientX;
        drag.y = e.clientY;
        if (!drag.moved && Math.hypot(e.clientX - drag.x0, e.clientY - drag.y0) < kClickSlop) return;
        if (!drag.moved) {
            // The first move counts from where the press was.
            drag.moved = true;
            return move(e.clientX - drag.x0, e.clientY - drag.y0);
        }
        return move(dx, dy);
    });

    // The drag keeps its own unrounded camera, so many small moves add up exactly.
    function move(dx, dy) {
        drag.camera =
            drag.mode === 'pan'
                ? pan(drag.camera, dx, dy, o.viewHeight())
                : orbit(drag.camera, -dx * kOrbitPerPixel, dy * kOrbitPerPixel);
        o.change(drag.camera, true);
    }

    const end = (e) => {
        if (!drag || e.pointerId !== drag.id) return;
        const d = drag;
        drag = null;
        el.classList.remove('panning', 'orbiting');
        if (el.hasPointerCapture(e.pointerId)) el.releasePointerCapture(e.pointerId);
        if (d.moved) o.release();
        else if (d.button === 0 && e.type === 'pointerup') o.pick(e.clientX, e.clientY);
    };
    el.addEventListener('pointerup', end);
    el.addEventListener('pointercancel', end);

    el.addEventListener(
        'wheel',
        (e) => {
            const cam = o.camera();
            if (!cam) return;
            e.preventDefault();
            // Lines (Firefox) and pages to pixels, then about 14% per notch of 100 pixels.
            const unit = e.deltaMode === 1 ? 16 : e.deltaMode === 2 ? 400 : 1;
            const factor = Math.exp(e.deltaY * unit * 0.0015);
            o.change(zoom(cam, factor), false);
        },
        { passive: false },
    );

    el.addEventListener('keydown', (e) => {
        const cam = o.camera();
        if (!cam || e.altKey || e.ctrlKey || e.metaKey) return;
        let next = null;
        const arrows = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1] };
        if (e.key in arrows) {
            const [ax, ay] = arrows[e.key];
            next = e.shiftKey
                ? pan(cam, ax * kKeyPan, ay * kKeyPan, o.viewHeight())
                : orbit(cam, -ax * kKeyOrbit, ay * kKeyOrbit);
        } else if (e.key === '+' || e.key === '=') {
            next = zoom(cam, 1 / kKeyZoom);
        } else if (e.key === '-' || e.key === '_') {
            next = zoom(cam, kKeyZoom);
        } else if (e.key === 'r' || e.key === 'R' || e.key === 'Home') {
            e.preventDefault();
            return o.reset();
        } else if (e.key === 'Enter') {
            e.preventDefault();
            return o.pickCentre();
        } else {
            return;
        }
        e.preventDefault();
        o.change(next, false);
    });
}
