// Camera math of the preview page: the server's pinhole camera written out again, so that the
// ray the page casts for a clicked pixel is the ray the server traced for that pixel, and the
// orbit / pan / zoom moves of the glTF Sample Viewer and <model-viewer>.
//
// The pinhole camera is engine/render/camera_rays.{h,cpp}, step for step and in the same
// order of floating-point operations (doubles in both):
//
//   f = normalize(look_at − position),  r = normalize(f × up),  u = r × f
//   d(x, y) = normalize(f + (2x/W − 1)·tan(fov/2)·(W/H)·r + (1 − 2y/H)·tan(fov/2)·u)
//
// with (x, y) in pixels from the top-left corner; pixel (i, j)'s first sample is its centre
// (i + ½, j + ½) (engine/render/render.cpp, spp = 1). r points to the right of the picture, so
// a camera looking along +z with +y up has +x on the left (docs/rendering.md).

export const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
export const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
export const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
export const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
export const cross = (a, b) => [
    a[1] * b[2] - a[2] * b[1],
    a[2] * b[0] - a[0] * b[2],
    a[0] * b[1] - a[1] * b[0],
];
// hypot rather than √(a·a), which underflows below ~1e-154 (a scene 1e-300 across) and
// overflows above ~1e154: the page's lengths are per interaction, never per pixel.
export const length = (a) => Math.hypot(a[0], a[1], a[2]);

/** v / |v|, the zero vector staying zero (engine/math/vec3.h normalize). */
export function normalize(v) {
    const len = length(v);
    return len > 0 ? [v[0] / len, v[1] / len, v[2] / len] : v;
}

/** The camera the server frames a scene with when none is given, for an image of `aspect` =
 *  width / height (engine/scene/scene.cpp default_camera): the bounds' centre seen from the
 *  side `view` names (the summary's `default_view`: '+z' for a scene with a model file, whose
 *  front faces +z; '-z' for spheres and triangles only), their bounding sphere (half the
 *  diagonal) just filling the narrower field of view; bounds flat in y (or x) from 45° above
 *  (or beside). */
export const DEFAULT_CAMERA_FLAT = 1e-6; // engine/scene/scene.h kDefaultCameraFlat

export function defaultCamera(bounds, aspect = 4 / 3, view = '-z') {
    const cam = { position: [0, 0, 0], look_at: [0, 0, 1], up: [0, 1, 0], fov_y_deg: 45 };
    if (!bounds || !bounds.min || !bounds.max) return cam;
    const { min: lo, max: hi } = bounds;
    if (lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2]) return cam;
    const c = scale(add(lo, hi), 0.5);
    const half = 0.5 * length(sub(hi, lo));
    const radius = half > 0 ? half : 1e-9; // 1e-9 for a point only, as the server does
    const halfFovY = (0.5 * cam.fov_y_deg * Math.PI) / 180.0;
    const halfFovX = aspect > 0 && Number.isFinite(aspect) ? Math.atan(Math.tan(halfFovY) * aspect) : halfFovY;
    const dist = radius / Math.sin(Math.min(halfFovY, halfFovX));
    // Bounds flat in y (a ground plane) or x are edge-on from ±z: seen from 45° above or beside
    // instead, as the server does (kDefaultCameraFlat).
    const e = sub(hi, lo);
    const flat = DEFAULT_CAMERA_FLAT * length(e);
    const dir = [0, 0, view === '+z' ? 1 : -1];
    if (e[1] <= flat) dir[1] = 1;
    else if (e[0] <= flat) dir[0] = 1;
    cam.look_at = c;
    cam.position = add(c, scale(normalize(dir), dist));
    return cam;
}

/** The frame of CameraRays (camera_rays.cpp's constructor) for a W × H image. */
export function cameraFrame(camera, width, height) {
    const forward = normalize(sub(camera.look_at, camera.position));
    let right = normalize(cross(forward, camera.up));
    let up = cross(right, forward);
    const tanHalf = Math.tan((0.5 * camera.fov_y_deg * Math.PI) / 180.0);
    up = scale(up, tanHalf);
    right = scale(right, (tanHalf * width) / height);
    return { origin: camera.position, forward, right, up, width, height };
}

/** The ray through image point (x, y) in pixels (x right, y down); unit direction
 *  (CameraRays::ray). */
export function cameraRay(camera, width, height, x, y) {
    const f = cameraFrame(camera, width, height);
    const a = (2.0 * x) / f.width - 1.0;
    const b = 1.0 - (2.0 * y) / f.height;
    const d = add(add(f.forward, scale(f.right, a)), scale(f.up, b));
    return { origin: [...f.origin], direction: normalize(d) };
}

/** The ray of pixel (i, j)'s centre: what a render with spp = 1 traces for that pixel. */
export function pixelRay(camera, width, height, i, j) {
    return cameraRay(camera, width, height, i + 0.5, j + 0.5);
}

/** Rodrigues' rotation of v about the unit axis k by angle θ. */
function rotate(v, k, theta) {
    const c = Math.cos(theta);
    const s = Math.sin(theta);
    return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
}

/** Keeps the view direction this far (radians) from the up axis, so `up` never becomes
 *  parallel to it (the server refuses such a camera). */
const kPoleMargin = (0.5 * Math.PI) / 180;

/**
 * Orbits the camera about its look_at point, as a turntable: `yaw` turns about the camera's
 * `up` axis, `pitch` tilts towards it (positive: the camera rises and looks down). The
 * distance to look_at, the up vector and the field of view are kept.
 */
export function orbit(camera, yaw, pitch) {
    const up = normalize(camera.up);
    const offset = rotate(sub(camera.position, camera.look_at), up, yaw);
    const r = length(offset);
    // Polar form about `up`: offset = r·(cos φ·up + sin φ·h), h ⟂ up.
    let h = sub(offset, scale(up, dot(offset, up)));
    if (length(h) < 1e-12 * r) {
        // On the axis: take the picture's downward direction as the way off it.
        const frame = cameraFrame(camera, 1, 1);
        h = scale(frame.up, -1);
    }
    h = normalize(h);
    const phi = Math.acos(Math.min(1, Math.max(-1, dot(offset, up) / r)));
    const next = Math.min(Math.PI - kPoleMargin, Math.max(kPoleMargin, phi - pitch));
    const moved = add(scale(up, r * Math.cos(next)), scale(h, r * Math.sin(next)));
    return { ...camera, position: add(camera.look_at, moved) };
}

/**
 * Pans by a drag of (dx, dy) CSS pixels on a view `viewHeight` pixels tall: the point of the
 * look_at plane under the cursor stays under it (position and look_at move together).
 */
export function pan(camera, dx, dy, viewHeight) {
    const frame = cameraFrame(camera, 1, 1);
    const dist = length(sub(camera.look_at, camera.position));
    // frame.up has length tan(fov/2): half the picture's height at distance 1.
    const perPixel = (2 * dist) / viewHeight;
    const right = normalize(frame.right);
    const move = add(scale(right, -dx * perPixel * length(frame.up)), scale(frame.up, dy * perPixel));
    return {
        ...camera,
        position: add(camera.position, move),
        look_at: add(camera.look_at, move),
    };
}

/** Moves the camera towards look_at (factor < 1) or away from it (> 1); the distance stays
 *  above `minDistance`, by default 1e-12 of look_at's largest coordinate (so that position still
 *  differs from it) and 1e-300 at least. Not a fixed length: a mesh 1e-20 across is framed
 *  from ~1e-20, and a floor of 1e-9 had thrown the camera out on the first zoom. */
export function zoom(camera, factor, minDistance = undefined) {
    const offset = sub(camera.position, camera.look_at);
    const dist = length(offset);
    const floor = minDistance ?? Math.max(1e-300, 1e-12 * Math.max(...camera.look_at.map(Math.abs)));
    const next = Math.max(dist * factor, floor);
    return { ...camera, position: add(camera.look_at, scale(offset, next / dist)) };
}

/** The camera with every number to 9 significant digits, and coordinates below 1e-12 of the
 *  camera's distance to look_at written as 0 (an orbit's 8.3e-17): short enough for a URL,
 *  and what the page renders and casts with, so a shared link reproduces the same pixels. */
export function roundCamera(camera) {
    const r = (x) => {
        const v = Number(x.toPrecision(9));
        return Object.is(v, -0) ? 0 : v;
    };
    const tiny = 1e-12 * length(sub(camera.position, camera.look_at));
    const point = (p) => p.map((x) => (Math.abs(x) < tiny ? 0 : r(x)));
    return {
        position: point(camera.position),
        look_at: point(camera.look_at),
        up: camera.up.map((x) => (Math.abs(x) < 1e-12 * length(camera.up) ? 0 : r(x))),
        fov_y_deg: r(camera.fov_y_deg),
    };
}

const isVec3 = (v) => Array.isArray(v) && v.length === 3 && v.every(Number.isFinite);

/** A usable camera from untrusted JSON (a URL, a scene document), or null: the same rules as
 *  the server's (docs/api.md: look_at ≠ position, up not parallel to the view, fov in (0, 180)). */
export function checkCamera(obj) {
    if (!obj || typeof obj !== 'object') return null;
    const cam = {
        position: obj.position ?? [0, 0, 0],
        look_at: obj.look_at ?? [0, 0, 1],
        up: obj.up ?? [0, 1, 0],
        fov_y_deg: obj.fov_y_deg ?? 45,
    };
    if (!isVec3(cam.position) || !isVec3(cam.look_at) || !isVec3(cam.up)) return null;
    if (!Number.isFinite(cam.fov_y_deg) || cam.fov_y_deg <= 0 || cam.fov_y_deg >= 180) return null;
    const f = sub(cam.look_at, cam.position);
    if (length(f) === 0 || length(cross(normalize(f), normalize(cam.up))) < 1e-9) return null;
    return cam;
}
