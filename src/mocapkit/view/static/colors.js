// Colours: the error scale (0 -> scale maximum) with its legend, and one colour per segment action.

import { Color } from "three";

/** Colour of the joints of a panel without errors (an original). */
export const PLAIN_JOINT = new Color(0.62, 0.72, 0.86);

/** The error scale as [fraction, r, g, b] stops: green at 0, yellow at half, red at the maximum. */
const STOPS = [
  [0.0, 0.16, 0.75, 0.35],
  [0.5, 0.95, 0.85, 0.2],
  [1.0, 0.9, 0.15, 0.15],
];

/**
 * The colour of `value` on a scale from 0 to `max` (clamped; values above the maximum are red).
 * @param {number} value
 * @param {number} max
 * @param {Color} out
 */
export function errorColor(value, max, out) {
  if (!Number.isFinite(value)) return out.setRGB(0.5, 0.5, 0.5);
  const f = max > 0 ? Math.min(Math.max(value / max, 0), 1) : 0;
  for (let k = 1; k < STOPS.length; k++) {
    const [f1, r1, g1, b1] = STOPS[k];
    if (f <= f1) {
      const [f0, r0, g0, b0] = STOPS[k - 1];
      const a = (f - f0) / (f1 - f0);
      return out.setRGB(r0 + a * (r1 - r0), g0 + a * (g1 - g0), b0 + a * (b1 - b0));
    }
  }
  const last = STOPS[STOPS.length - 1];
  return out.setRGB(last[1], last[2], last[3]);
}

/**
 * Draw the error scale into a 2-D canvas: a gradient bar from 0 to `max` with five ticks (cm).
 * @param {HTMLCanvasElement} canvas
 * @param {number} max   the scale's maximum (cm)
 */
export function drawLegend(canvas, max) {
  const ctx = canvas.getContext("2d");
  const w = canvas.width;
  const h = canvas.height;
  ctx.clearRect(0, 0, w, h);
  const x0 = 14;
  const x1 = w - 20;
  const c = new Color();
  for (let x = x0; x <= x1; x++) {
    errorColor(((x - x0) / (x1 - x0)) * max, max, c);
    ctx.fillStyle = `#${c.getHexString()}`;
    ctx.fillRect(x, 2, 1, 12);
  }
  ctx.fillStyle = "#d8dde6";
  ctx.font = "11px sans-serif";
  ctx.textBaseline = "top";
  ctx.textAlign = "center";
  for (let k = 0; k <= 4; k++) {
    const x = x0 + (k / 4) * (x1 - x0);
    ctx.fillRect(Math.round(x), 14, 1, 4);
    ctx.fillText(formatNumber((k / 4) * max), x, 20);
  }
}

/** A short text for a number of cm or degrees. */
export function formatNumber(v) {
  if (v === 0) return "0";
  const a = Math.abs(v);
  return a >= 100 ? v.toFixed(0) : a >= 10 ? v.toFixed(1) : a >= 0.1 ? v.toFixed(2) : v.toPrecision(2);
}

const PALETTE = ["#4e79a7", "#f28e2b", "#59a14f", "#b07aa1", "#edc948", "#76b7b2", "#ff9da7", "#9c755f", "#e15759", "#bab0ac"];

/** A colour per segment key (action letter or label), stable across the page. */
export function segmentColor(key, index) {
  if (typeof key === "string" && key.length > 0) {
    let h = 0;
    if (/^[A-Z]$/.test(key)) h = key.charCodeAt(0) - 65;
    else for (let i = 0; i < key.length; i++) h = (h * 31 + key.charCodeAt(i)) >>> 0;
    return PALETTE[h % PALETTE.length];
  }
  return PALETTE[index % PALETTE.length];
}
