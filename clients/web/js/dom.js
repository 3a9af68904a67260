// Small DOM and number-formatting helpers. Text from the server is only ever set as text
// (textContent), never parsed as HTML.

const SVG_NS = 'http://www.w3.org/2000/svg';

function build(el, attrs, children) {
    for (const [k, v] of Object.entries(attrs ?? {})) {
        if (v === undefined || v === null || v === false) continue;
        if (k === 'class') el.setAttribute('class', v);
        else if (k === 'text') el.textContent = v;
        else if (k.startsWith('on')) el.addEventListener(k.slice(2), v);
        else el.setAttribute(k, v === true ? '' : String(v));
    }
    for (const c of children.flat(Infinity)) {
        if (c === null || c === undefined || c === false) continue;
        el.append(c instanceof Node ? c : document.createTextNode(String(c)));
    }
    return el;
}

/** h('dt', {class: 'x'}, 'text', child, …) → an HTML element. */
export const h = (tag, attrs, ...children) => build(document.createElement(tag), attrs, children);

/** The same for SVG elements. */
export const s = (tag, attrs, ...children) => build(document.createElementNS(SVG_NS, tag), attrs, children);

/** A number for people: up to `digits` significant digits, no exponent for ordinary sizes. */
export function num(x, digits = 6) {
    if (typeof x !== 'number') return String(x);
    if (!Number.isFinite(x)) return String(x);
    if (x === 0) return '0';
    const a = Math.abs(x);
    if (a >= 1e-4 && a < 1e9) return String(Number(x.toPrecision(digits)));
    return x.toExponential(digits - 1);
}

/** "(0, 0, 7.26795)" */
export const vec = (v, digits = 6) => (Array.isArray(v) ? `(${v.map((x) => num(x, digits)).join(', ')})` : '—');

/** A definition list from [term, value] pairs; a value may be a Node. `full` adds the exact
 *  text as a tooltip (the 17 significant digits the API returns). */
export function definitions(rows, cls = 'facts') {
    return h(
        'dl',
        { class: cls },
        rows
            .filter((r) => r)
            .map(([term, value, full]) => [
                h('dt', {}, term),
                h('dd', { title: full ?? undefined }, value instanceof Node ? value : String(value)),
            ]),
    );
}

/** Linear RGB → a CSS sRGB colour (IEC 61966-2-1), clamped to [0, 1]. */
export function srgb(rgb) {
    const enc = (c) => {
        const x = Math.min(1, Math.max(0, c));
        const v = x <= 0.0031308 ? 12.92 * x : 1.055 * x ** (1 / 2.4) - 0.055;
        return Math.round(v * 255);
    };
    const [r, g, b] = (rgb ?? [0, 0, 0]).map(enc);
    return { css: `rgb(${r}, ${g}, ${b})`, light: 0.2126 * r + 0.7152 * g + 0.0722 * b > 140 };
}
