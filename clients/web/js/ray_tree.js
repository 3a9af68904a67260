// The Whitted ray tree of one ray, drawn as the CS3241 tutorial (question 2) draws it: the eye
// ray reaches I1; each point where light intensity is computed (I1, I2, … in depth-first order,
// reflected child before refracted child) sends its shadow rays towards the lights, and its
// reflected and refracted rays on to the next points. A shadow ray that reaches its light is
// drawn plain, one blocked by an object is drawn broken with the blocker's name; a point whose
// shadow rays are all blocked uses the ambient term only.
//
// Input: the response of POST /v1/scenes/{id}/trace (API.md). Output: an SVG whose nodes can be
// focused and chosen (Tab, Enter) to show their details, and a plain-text summary.

import { definitions, h, num, s, srgb, vec } from './dom.js';

const kCol = 120; // horizontal room per leaf
const kCaption = 34; // the two caption lines under a node
const kRow = 122; // vertical room per level
const kR = 19; // node radius
const kTop = 34;

/** Lays the tree out: leaves left to right in depth-first order, a parent centred over its
 *  children. Returns [{node, depth, x, parent, kind}] in depth-first order. */
export function layout(root) {
    const out = [];
    let nextLeaf = 0;
    const visit = (node, depth, parent, kind) => {
        const item = { node, depth, parent, kind, x: 0 };
        out.push(item);
        const kids = [];
        if (node.reflected) kids.push(visit(node.reflected, depth + 1, item, 'reflected'));
        if (node.refracted) kids.push(visit(node.refracted, depth + 1, item, 'refracted'));
        item.x = kids.length ? kids.reduce((a, k) => a + k.x, 0) / kids.length : nextLeaf++;
        return item;
    };
    if (root) visit(root, 1, null, 'eye');
    return { items: out, leaves: Math.max(nextLeaf, 1) };
}

const termsShort = (terms) =>
    (terms ?? []).length === 1 && terms[0] === 'ambient' ? 'ambient only' : 'ambient + diffuse + specular';

/** The nodes of a tree in depth-first order. */
function nodes(root) {
    const out = [];
    const walk = (n) => {
        if (!n) return;
        out.push(n);
        walk(n.reflected);
        walk(n.refracted);
    };
    walk(root);
    return out;
}

/** One sentence, as the tutorial answers: which points take all three Phong terms, and why
 *  the others take the ambient term only. */
export function summarySentence(summary, root) {
    if (!summary || summary.points === 0) return 'The ray hits nothing: no point needs its intensity computed.';
    const list = (a) => a.join(', ');
    const parts = [`${summary.points} point${summary.points === 1 ? ' needs its' : 's need their'} light intensity computed`];
    if (summary.full_phong.length) parts.push(`all three Phong terms at ${list(summary.full_phong)}`);
    if (summary.ambient_only.length) {
        const ambient = nodes(root).filter((n) => summary.ambient_only.includes(n.label));
        const blocked = ambient.some((n) => (n.shadow_rays ?? []).some((r) => r.blocked_by !== null));
        const why = blocked
            ? 'their shadow rays are blocked'
            : ambient.some((n) => n.shadow_rays?.length)
              ? 'no light is in front of them'
              : 'the scene has no point or directional light';
        parts.push(`the ambient term only at ${list(summary.ambient_only)} (${why})`);
    }
    return `${parts.join('; ')}.`;
}

function nodeDetails(node) {
    const shadow = h(
        'ul',
        { class: 'shadow-list' },
        (node.shadow_rays ?? []).map((r) =>
            h(
                'li',
                {},
                `light ${r.light}: `,
                r.facing === false
                    ? 'behind the surface (adds nothing)'
                    : r.blocked_by === null
                      ? 'reaches the light'
                      : `blocked by ${r.blocked_by}`,
            ),
        ),
    );
    return definitions([
        ['node', `${node.label}: ${node.name} (object ${node.object})`],
        ['t', num(node.t, 8), String(node.t)],
        ['position', vec(node.point), JSON.stringify(node.point)],
        ['normal', vec(node.normal), JSON.stringify(node.normal)],
        node.front_face !== undefined && ['front face', node.front_face ? 'yes' : 'no (from inside or behind)'],
        ['Phong terms', (node.terms ?? []).join(', ')],
        ['shadow rays', node.shadow_rays?.length ? shadow : 'none (no point or directional light)'],
        ['colour', h('span', {}, h('span', { class: 'swatch' }), vec(node.color, 4))],
        node.total_internal_reflection && ['refraction', 'total internal reflection: nothing transmitted'],
    ]);
}

/** Draws `trace` into `container` (replacing what was there). */
export function renderRayTree(container, trace) {
    container.replaceChildren();
    const root = trace?.tree ?? null;
    container.append(h('h3', {}, 'Ray tree'), h('p', { class: 'tree-summary' }, summarySentence(trace?.summary, root)));
    if (!root) return;
    const { items, leaves } = layout(root);
    const depth = Math.max(...items.map((i) => i.depth));
    const width = Math.max(leaves * kCol + 90, 260);
    const height = kTop + depth * kRow + 24;
    const X = (item) => width / 2 + (item.x - (leaves - 1) / 2) * kCol;
    const Y = (d) => kTop + d * kRow - kRow / 2;
    const svg = s('svg', {
        class: 'ray-tree',
        viewBox: `0 0 ${width} ${height}`,
        width,
        height,
        role: 'group',
        'aria-label': `Ray tree: ${summarySentence(trace.summary, root)}`,
    });
    const defs = s(
        'defs',
        {},
        s(
            'marker',
            { id: 'arrow', viewBox: '0 0 10 10', refX: 9, refY: 5, markerWidth: 7, markerHeight: 7, orient: 'auto-start-reverse' },
            s('path', { d: 'M 0 0 L 10 5 L 0 10 z', class: 'arrow-head' }),
        ),
    );
    svg.append(defs);
    // The eye, and its ray to I1.
    const rootItem = items[0];
    const eyeY = 14;
    svg.append(
        s('text', { x: X(rootItem), y: eyeY - 2, class: 'eye', 'text-anchor': 'middle' }, 'eye'),
        s('line', { x1: X(rootItem), y1: eyeY + 4, x2: X(rootItem), y2: Y(1) - kR - 2, class: 'edge primary', 'marker-end': 'url(#arrow)' }),
    );
    const details = h('div', { class: 'node-details', 'aria-live': 'polite' });
    const groups = [];
    const select = (idx) => {
        groups.forEach((g, i) => g.classList.toggle('selected', i === idx));
        details.replaceChildren(h('h4', {}, `${items[idx].node.label} — ${items[idx].node.name}`), nodeDetails(items[idx].node));
        const sw = details.querySelector('.swatch');
        if (sw) sw.style.background = srgb(items[idx].node.color).css;
    };
    items.forEach((item, idx) => {
        const { node } = item;
        const x = X(item);
        const y = Y(item.depth);
        if (item.parent) {
            // From under the parent's caption to the child's disc.
            const px = X(item.parent);
            const py = Y(item.parent.depth) + kR + kCaption;
            const len = Math.hypot(x - px, y - py);
            const ux = (x - px) / len;
            const uy = (y - py) / len;
            svg.append(
                s('line', {
                    x1: px, y1: py, x2: x - ux * (kR + 2), y2: y - uy * (kR + 2),
                    class: `edge ${item.kind}`, 'marker-end': 'url(#arrow)',
                }),
                s('text', { x: px + (x - px) * 0.5 + (x < px ? -7 : x > px ? 7 : 6), y: py + (y - py) * 0.5, class: `edge-label ${item.kind}`, 'text-anchor': x < px ? 'end' : 'start' },
                    item.kind),
            );
        }
        const g = s('g', {
            class: `node ${node.terms?.length === 1 ? 'ambient-only' : 'full'}`,
            tabindex: 0,
            role: 'button',
            'data-label': node.label,
            'aria-label': `${node.label}: ${node.name}, ${termsShort(node.terms)}`,
        });
        // Shadow rays leave sideways, one per point or directional light, on the side away
        // from the ray that arrived (a left child's parent is to its upper right).
        const side = item.parent && X(item.parent) > x ? -1 : 1;
        (node.shadow_rays ?? []).forEach((r, k) => {
            const deg = -22 + 30 * k;
            const a = (side > 0 ? deg : 180 - deg) * (Math.PI / 180);
            const x1 = x + Math.cos(a) * kR;
            const y1 = y + Math.sin(a) * kR;
            const x2 = x + Math.cos(a) * (kR + 30);
            const y2 = y + Math.sin(a) * (kR + 30);
            const state = r.facing === false ? 'away' : r.blocked_by === null ? 'free' : 'blocked';
            g.append(s('line', { x1, y1, x2, y2, class: `shadow ${state}` }));
            const blocker = String(r.blocked_by ?? '');
            const mark = state === 'free' ? `L${r.light}` : state === 'away' ? `L${r.light} ·` : `L${r.light} ✕ ${blocker.length > 10 ? `${blocker.slice(0, 9)}…` : blocker}`;
            g.append(s('text', { x: x2 + 3 * side, y: y2 + 4, 'text-anchor': side > 0 ? 'start' : 'end', class: `shadow-label ${state}` }, mark));
            if (state === 'blocked')
                g.append(s('title', {}, `shadow ray to light ${r.light} blocked by ${r.blocked_by}`));
        });
        const fill = srgb(node.color);
        const circle = s('circle', { cx: x, cy: y, r: kR, class: 'node-disc' });
        circle.style.fill = fill.css;
        g.append(
            circle,
            s('text', { x, y: y + 5, 'text-anchor': 'middle', class: `node-label ${fill.light ? 'dark' : 'light'}` }, node.label),
            s('text', { x, y: y + kR + 15, 'text-anchor': 'middle', class: 'node-name' }, node.name.length > 18 ? `${node.name.slice(0, 17)}…` : node.name),
            s('text', { x, y: y + kR + 29, 'text-anchor': 'middle', class: 'node-terms' }, node.terms?.length === 1 ? 'ambient only' : 'A + D + S'),
        );
        g.addEventListener('click', () => select(idx));
        g.addEventListener('keydown', (e) => {
            if (e.key === 'Enter' || e.key === ' ') {
                e.preventDefault();
                select(idx);
            }
        });
        groups.push(g);
        svg.append(g);
    });
    container.append(h('div', { class: 'tree-scroll' }, svg), details);
    select(0);
}
