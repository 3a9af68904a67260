// The scene panel (POST/GET /v1/scenes summaries) and the hit panel (one intersect answer).

import { definitions, h, num, vec } from './dom.js';

const yesNo = (b) => (b ? 'yes' : 'no');

function featureChips(features) {
    const names = { shadows: 'shadows', reflection: 'reflection', refraction: 'refraction', textures: 'textures' };
    return h(
        'ul',
        { class: 'chips', 'aria-label': 'features the scene needs' },
        Object.entries(features ?? {}).map(([k, v]) =>
            h('li', { class: v ? 'on' : 'off', title: v ? `${k}: needed` : `${k}: not needed (skipped)` }, `${v ? '✓' : '–'} ${names[k] ?? k}`),
        ),
    );
}

/** API.md `topology`: one row per mesh object (OpenMesh half-edge statistics). */
function topologyTable(topology) {
    const cols = [
        ['name', 'object'],
        ['vertices', 'vertices'],
        ['triangles', 'triangles'],
        ['closed', 'closed'],
        ['boundary_edges', 'boundary edges'],
        ['boundary_loops', 'boundary loops'],
        ['non_manifold_edges', 'non-manifold edges'],
        ['non_manifold_vertices', 'non-manifold vertices'],
        ['components', 'components'],
        ['euler_characteristic', 'Euler χ'],
        ['consistently_oriented', 'oriented'],
        ['degenerate_triangles', 'degenerate'],
        ['sign', 'inside test'],
    ];
    const cell = (v) => (typeof v === 'boolean' ? yesNo(v) : v === undefined ? '—' : String(v));
    return h(
        'div',
        { class: 'table-scroll' },
        h(
            'table',
            { class: 'topology' },
            h('caption', {}, 'Topology (half-edge structure)'),
            h('thead', {}, h('tr', {}, cols.map(([, label]) => h('th', { scope: 'col' }, label)))),
            h('tbody', {}, topology.map((t) => h('tr', {}, cols.map(([key]) => h('td', {}, cell(key === 'name' ? (t.name ?? `object ${t.object}`) : t[key])))))),
        ),
    );
}

/** Fills `el` with a scene summary; `label` is what the person called it (a file name). */
export function renderSceneInfo(el, summary, label) {
    el.replaceChildren();
    if (!summary) {
        el.append(h('p', { class: 'muted' }, 'No scene yet: drop a model file on the page, pick one with “Open model…”, or choose a registered scene.'));
        return;
    }
    const b = summary.bounds ?? {};
    el.append(
        definitions([
            label && ['name', label],
            ['id', h('code', {}, summary.id)],
            ['objects', String(summary.objects)],
            ['triangles', num(summary.triangles)],
            ['spheres', String(summary.spheres)],
            ['bounds', h('span', {}, vec(b.min, 4), ' – ', vec(b.max, 4)), JSON.stringify(b)],
            summary.build_ms !== undefined && ['build', `${num(summary.build_ms, 3)} ms`],
            summary.memory_bytes !== undefined && ['memory', `${num(summary.memory_bytes / 1024, 3)} KiB`],
            ['features', featureChips(summary.features)],
        ]),
    );
    if (Array.isArray(summary.topology) && summary.topology.length) el.append(topologyTable(summary.topology));
    if (summary.warnings?.length) {
        el.append(h('details', { class: 'warnings', open: summary.warnings.length <= 3 }, h('summary', {}, `${summary.warnings.length} warning${summary.warnings.length > 1 ? 's' : ''}`), h('ul', {}, summary.warnings.map((w) => h('li', {}, w)))));
    }
}

/** Fills `el` with the answer for a clicked pixel. */
export function renderHit(el, { pixel, size, ray, answer }) {
    el.replaceChildren();
    const where = `pixel (${pixel[0]}, ${pixel[1]}) of ${size.width} × ${size.height}`;
    const rayRows = [
        ['ray origin', vec(ray.origin), JSON.stringify(ray.origin)],
        ['ray direction', vec(ray.direction), JSON.stringify(ray.direction)],
    ];
    const hit = answer.hit;
    if (!hit?.hit) {
        el.append(h('p', { class: 'hit-title miss' }, `Miss — the ray through ${where} hits nothing.`), definitions([...rayRows, ['precision', answer.precision]]));
        return;
    }
    el.append(
        h('p', { class: 'hit-title' }, h('strong', { class: 'hit-name' }, hit.name), ` (object ${hit.object}) at ${where}`),
        definitions([
            ['object', `${hit.name} (index ${hit.object})`],
            ['t', num(hit.t, 10), String(hit.t)],
            hit.t_err !== undefined && ['t error bound', num(hit.t_err, 3), String(hit.t_err)],
            ['point', vec(hit.point), JSON.stringify(hit.point)],
            ['normal', vec(hit.normal), JSON.stringify(hit.normal)],
            ['primitive', String(hit.primitive)],
            ['barycentric', vec(hit.barycentric), JSON.stringify(hit.barycentric)],
            ['front face', hit.front_face === undefined ? '—' : yesNo(hit.front_face)],
            ['precision', `${answer.precision} (the path that answered)`],
            ...rayRows,
        ]),
    );
}
