// The timeline: play/pause, scrub bar, speed, frame and time read-outs, and the strip canvas with the
// segments, cuts and playhead of `scene.segments`. It owns the current frame and calls `onFrame(i)`.

import { nearestSample, sampleAt } from "./arrays.js";
import { segmentColor } from "./colors.js";

export class Timeline {
  /**
   * @param {Float64Array} times   the timeline's clock (seconds, increasing)
   * @param {object|null} segments  `scene.segments`
   * @param {(frame: number) => void} onFrame  draws frame `frame` (synchronously)
   * @param {() => void} onPlay  called when playing starts (the owner then calls `tick` every animation frame)
   */
  constructor(times, segments, onFrame, onPlay) {
    this.times = times;
    this.segments = segments;
    this.onFrame = onFrame;
    this.onPlay = onPlay;
    this.frame = 0;
    this.playing = false;
    this.speed = 1;
    this.clock = times.length ? times[0] : 0; // the playback time (s) while playing
    this.lastTick = null;
    this.play = document.getElementById("play");
    this.scrub = document.getElementById("scrub");
    this.speedSelect = document.getElementById("speed");
    this.frameText = document.getElementById("frame");
    this.timeText = document.getElementById("time");
    this.strip = document.getElementById("strip");
    document.getElementById("frame-count").textContent = String(times.length);
    // fixed widths (in digits) so that the readouts, and so the range beside them, never change size
    const widest = Math.max(...[this.start, this.end].map((t) => Math.abs(t).toFixed(3).length + (t < 0 ? 1 : 0)));
    // (a fixed width with some slack: a font without tabular figures may draw some digits wider than "0")
    this.frameText.style.width = `${String(Math.max(times.length - 1, 0)).length + 0.5}ch`;
    this.timeText.style.width = `${widest + 0.5}ch`;
    this.scrub.max = String(Math.max(times.length - 1, 0));
    this.bind();
    this.resizeStrip();
  }

  get start() { return this.times.length ? this.times[0] : 0; }
  get end() { return this.times.length ? this.times[this.times.length - 1] : 0; }

  bind() {
    this.play.addEventListener("click", () => this.toggle());
    this.scrub.addEventListener("input", () => this.setFrame(Number(this.scrub.value)));
    this.speedSelect.addEventListener("change", () => { this.speed = Number(this.speedSelect.value) || 1; });
    window.addEventListener("keydown", (e) => {
      const tag = e.target && e.target.tagName;
      const range = tag === "INPUT" && e.target.type === "range"; // steps with the arrows by itself
      if (e.code === "Space" && (range || (tag !== "INPUT" && tag !== "TEXTAREA"))) {
        e.preventDefault();
        if (!e.repeat) this.toggle();
      } else if ((e.code === "ArrowRight" || e.code === "ArrowLeft") && tag !== "INPUT" && tag !== "SELECT") {
        e.preventDefault();
        this.pause();
        this.setFrame(this.frame + (e.code === "ArrowRight" ? 1 : -1));
      }
    });
    // A button activates on the space key's release: keep space to the toggle above.
    window.addEventListener("keyup", (e) => { if (e.code === "Space" && e.target.tagName === "BUTTON") e.preventDefault(); });
    let dragging = false;
    const scrubTo = (e) => {
      const rect = this.strip.getBoundingClientRect();
      const f = Math.min(Math.max((e.clientX - rect.left) / rect.width, 0), 1);
      this.pause();
      this.setFrame(nearestSample(this.times, this.start + f * (this.end - this.start)));
    };
    this.strip.addEventListener("pointerdown", (e) => {
      dragging = true;
      this.strip.setPointerCapture(e.pointerId);
      scrubTo(e);
    });
    this.strip.addEventListener("pointermove", (e) => { if (dragging) scrubTo(e); });
    const stop = () => { dragging = false; };
    this.strip.addEventListener("pointerup", stop);
    this.strip.addEventListener("pointercancel", stop);
    new ResizeObserver(() => this.resizeStrip()).observe(this.strip);
  }

  /** Show frame `i` (clamped to the timeline): read-outs, strip, then `onFrame`. */
  setFrame(i) {
    const n = this.times.length;
    const f = Math.min(Math.max(Math.round(Number(i)) || 0, 0), Math.max(n - 1, 0));
    this.frame = f;
    if (!this.playing) this.clock = n ? this.times[f] : 0;
    this.scrub.value = String(f);
    this.frameText.textContent = String(f);
    this.timeText.textContent = n ? this.times[f].toFixed(3) : "0.000";
    this.drawStrip();
    this.onFrame(f);
  }

  toggle() { if (this.playing) this.pause(); else this.start_(); }

  start_() {
    if (this.times.length < 2) return;
    if (this.frame >= this.times.length - 1) this.clock = this.start;
    else this.clock = this.times[this.frame];
    this.playing = true;
    this.lastTick = null;
    this.play.textContent = "pause";
    this.onPlay();
  }

  pause() {
    this.playing = false;
    this.play.textContent = "play";
  }

  /**
   * Advance the playback clock to the animation time `now` (ms); returns true while playing.
   * The clock wraps to the start after the last frame.
   */
  tick(now) {
    if (!this.playing) return false;
    if (this.lastTick !== null) {
      this.clock += ((now - this.lastTick) / 1000) * this.speed;
      if (this.clock > this.end) this.clock = this.start + ((this.clock - this.start) % Math.max(this.end - this.start, 1e-9));
    }
    this.lastTick = now;
    const f = sampleAt(this.times, this.clock);
    if (f !== this.frame) this.setFrame(f);
    return true;
  }

  resizeStrip() {
    const w = Math.max(1, Math.round(this.strip.clientWidth * devicePixelRatio));
    const h = Math.max(1, Math.round(this.strip.clientHeight * devicePixelRatio));
    if (this.strip.width !== w || this.strip.height !== h) {
      this.strip.width = w;
      this.strip.height = h;
    }
    this.drawStrip();
  }

  /** x (canvas pixels) of time `t`. */
  x(t) {
    const span = this.end - this.start;
    return span > 0 ? ((t - this.start) / span) * this.strip.width : 0;
  }

  drawStrip() {
    const ctx = this.strip.getContext("2d");
    const w = this.strip.width;
    const h = this.strip.height;
    const s = devicePixelRatio;
    ctx.fillStyle = "#1d2026";
    ctx.fillRect(0, 0, w, h);
    const band = Math.round(h * 0.55);
    ctx.font = `${Math.round(11 * s)}px sans-serif`;
    ctx.textBaseline = "middle";
    const segs = (this.segments && this.segments.segments) || [];
    segs.forEach((seg, k) => {
      const key = seg.action || seg.label || "";
      const x0 = this.x(seg.t0);
      const x1 = this.x(seg.t1);
      ctx.fillStyle = segmentColor(key, k);
      ctx.globalAlpha = 0.55;
      ctx.fillRect(x0, 0, Math.max(x1 - x0, 1), band);
      ctx.globalAlpha = 1;
      const text = [seg.action, seg.label].filter((v) => v !== null && v !== undefined && v !== "").join(" · ");
      if (text && x1 - x0 > 10 * s) {
        ctx.save();
        ctx.beginPath();
        ctx.rect(x0, 0, x1 - x0, band);
        ctx.clip();
        ctx.fillStyle = "#ffffff";
        ctx.fillText(text, x0 + 4 * s, band / 2);
        ctx.restore();
      }
    });
    // Time axis: about one tick per 80 CSS pixels, at a round step.
    const span = this.end - this.start;
    ctx.fillStyle = "#8e97a6";
    ctx.textBaseline = "alphabetic";
    if (span > 0) {
      const raw = (span * 80 * s) / w;
      const p = 10 ** Math.floor(Math.log10(raw));
      const step = [1, 2, 5, 10].map((m) => m * p).find((v) => v >= raw);
      const digits = Math.max(0, -Math.floor(Math.log10(step)));
      for (let t = Math.ceil(this.start / step) * step; t <= this.end + 1e-9; t += step) {
        const x = Math.round(this.x(t));
        ctx.fillRect(x, band, 1, 4 * s);
        ctx.fillText(`${t.toFixed(digits)}s`, Math.min(x + 2 * s, w - 30 * s), h - 3 * s);
      }
    }
    const cuts = (this.segments && this.segments.cuts) || [];
    ctx.fillStyle = "#ffffff";
    for (const cut of cuts) ctx.fillRect(Math.round(this.x(cut.time_s)) - Math.floor(s), 0, Math.max(2, Math.round(2 * s)), band + 6 * s);
    if (this.times.length) {
      ctx.fillStyle = "#ff5f56";
      ctx.fillRect(Math.round(this.x(this.times[this.frame])) - Math.floor(s), 0, Math.max(2, Math.round(2 * s)), h);
    }
  }
}
