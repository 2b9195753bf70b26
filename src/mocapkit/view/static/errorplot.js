// The 2-D plot of one IMU sensor's angle error over time: the error curve, the keyframes as ticks under the axis, the
// bound as a dashed line and the playhead. The static part is drawn once per size into an off-screen
// canvas; each frame copies it and draws the playhead.

import { formatNumber } from "./colors.js";

export class ErrorPlot {
  /**
   * @param {HTMLCanvasElement} canvas
   * @param {{name: string, times: Float64Array, error: Float32Array|null, keyframes: Float64Array|null,
   *          bound: number|null, maxError: number|null}} sensor
   * @param {number} start  the timeline's first time (s)
   * @param {number} end    the timeline's last time (s)
   */
  constructor(canvas, sensor, start, end) {
    this.canvas = canvas;
    this.sensor = sensor;
    this.start = start;
    this.end = end > start ? end : start + 1;
    this.background = document.createElement("canvas");
    this.t = start;
    new ResizeObserver(() => this.resize()).observe(canvas);
    this.resize();
  }

  resize() {
    const s = devicePixelRatio;
    const w = Math.max(1, Math.round(this.canvas.clientWidth * s));
    const h = Math.max(1, Math.round(this.canvas.clientHeight * s));
    this.canvas.width = w;
    this.canvas.height = h;
    this.background.width = w;
    this.background.height = h;
    this.box = { left: 34 * s, right: w - 6 * s, top: 16 * s, bottom: h - 20 * s };
    this.drawStatic();
    this.draw(this.t);
  }

  x(t) {
    const b = this.box;
    return b.left + ((t - this.start) / (this.end - this.start)) * (b.right - b.left);
  }

  y(v) {
    const b = this.box;
    return b.bottom - (v / this.yMax) * (b.bottom - b.top);
  }

  drawStatic() {
    const { name, times, error, keyframes, bound, maxError } = this.sensor;
    const s = devicePixelRatio;
    const ctx = this.background.getContext("2d");
    const w = this.background.width;
    const h = this.background.height;
    const b = this.box;
    let top = Math.max(bound || 0, maxError || 0);
    if (error) for (const v of error) if (Number.isFinite(v) && v > top) top = v;
    this.top = top > 0 ? top : 1;
    this.yMax = this.top * 1.15;
    ctx.fillStyle = "#1d2026";
    ctx.fillRect(0, 0, w, h);
    ctx.font = `${Math.round(10 * s)}px sans-serif`;
    ctx.fillStyle = "#d8dde6";
    ctx.textBaseline = "top";
    // the title: the sensor's name, shortened with an ellipsis when long, then the error's summary in full
    let summary = ": error (°)";
    if (maxError !== null && maxError !== undefined) summary += ` max ${formatNumber(maxError)}`;
    if (keyframes) summary += `, ${keyframes.length} keyframes`;
    const room = w - 4 * s - ctx.measureText(summary).width;
    let shown = name;
    if (ctx.measureText(shown).width > room) {
      let n = shown.length;
      while (n > 1 && ctx.measureText(`${shown.slice(0, n)}…`).width > room) n--;
      shown = `${shown.slice(0, n)}…`;
    }
    this.canvas.title = name + summary; // the whole title on hover
    this.canvas.dataset.drawnTitle = shown + summary;
    ctx.fillText(shown + summary, 2 * s, 2 * s);
    // Axes and y ticks.
    ctx.fillStyle = "#5b6474";
    ctx.fillRect(b.left, b.top, 1, b.bottom - b.top);
    ctx.fillRect(b.left, b.bottom, b.right - b.left, 1);
    ctx.fillStyle = "#8e97a6";
    ctx.textBaseline = "middle";
    ctx.textAlign = "right";
    for (const v of [0, this.top / 2, this.top]) {
      ctx.fillText(formatNumber(v), b.left - 3 * s, this.y(v));
    }
    ctx.textAlign = "left";
    ctx.textBaseline = "alphabetic";
    ctx.fillText(`${formatNumber(this.start)}s`, b.left, h - 2 * s);
    ctx.textAlign = "right";
    ctx.fillText(`${formatNumber(this.end)}s`, b.right, h - 2 * s);
    ctx.textAlign = "left";
    // Keyframes: short ticks under the bottom axis (lines across the plot would hide it when there are many).
    if (keyframes) {
      ctx.fillStyle = "#ffd166";
      for (const t of keyframes) ctx.fillRect(Math.round(this.x(t)), b.bottom + 1 * s, Math.max(1, Math.round(s)), 5 * s);
    }
    // The bound: a dashed line.
    if (bound !== null && bound !== undefined) {
      ctx.strokeStyle = "#ff7b72";
      ctx.lineWidth = s;
      ctx.setLineDash([5 * s, 4 * s]);
      ctx.beginPath();
      ctx.moveTo(b.left, this.y(bound));
      ctx.lineTo(b.right, this.y(bound));
      ctx.stroke();
      ctx.setLineDash([]);
      ctx.fillStyle = "#ff7b72";
      ctx.textAlign = "right";
      ctx.fillText(`bound ${formatNumber(bound)}`, b.right, this.y(bound) - 2 * s);
      ctx.textAlign = "left";
    }
    // The error curve (a polyline through the finite samples).
    if (error && times) {
      ctx.strokeStyle = "#4fc3f7";
      ctx.lineWidth = 1.25 * s;
      ctx.beginPath();
      let pen = false;
      for (let i = 0; i < error.length; i++) {
        const v = error[i];
        if (!Number.isFinite(v)) { pen = false; continue; }
        const x = this.x(times[i]);
        const y = this.y(v);
        if (pen) ctx.lineTo(x, y);
        else ctx.moveTo(x, y);
        pen = true;
      }
      ctx.stroke();
    } else {
      ctx.fillStyle = "#8e97a6";
      ctx.fillText("no error (one of original / decode missing)", b.left + 6 * s, (b.top + b.bottom) / 2);
    }
  }

  /** Copy the static plot and draw the playhead at time `t`. */
  draw(t) {
    this.t = t;
    const ctx = this.canvas.getContext("2d");
    ctx.drawImage(this.background, 0, 0);
    const s = devicePixelRatio;
    ctx.fillStyle = "#ff5f56";
    ctx.fillRect(Math.round(this.x(t)) - Math.floor(s / 2), this.box.top, Math.max(1, Math.round(1.5 * s)), this.box.bottom - this.box.top);
  }
}
