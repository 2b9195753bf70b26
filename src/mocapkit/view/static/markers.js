// A marker panel: the markers at the current frame as spheres, their trajectories as faint lines, the
// fitted curves of `filter --json` as lines of another colour and the knots as bigger spheres; the
// trajectories, curves and knots are drawn within a time window around the current time (the trail).

import {
  BufferAttribute, BufferGeometry, Color, InstancedMesh, LineBasicMaterial, LineSegments, Matrix4,
  MeshLambertMaterial, SphereGeometry, Vector3,
} from "three";
import { decodeArray, sampleAt } from "./arrays.js";
import { Panel, textSprite, unitScale } from "./panel.js";

const MARKER = new Color("#9fb7db");
const TRAJECTORY = new Color("#7d8796");
const FITTED = new Color("#f28e2b");
const KNOT = new Color("#ffd166");

/**
 * Line segments joining consecutive finite samples of each marker of an (n, M, 3) array, in time order:
 * the segments ending at sample k (joining k - 1 and k) come before those ending at k + 1, so the
 * segments within a window of samples are one contiguous range.
 * @returns {{xyz: Float32Array, starts: Uint32Array}}  xyz pairs; `starts[k]` = number of segments
 *   ending before sample k (k = 0..n)
 */
function trajectorySegments(flat, n, M) {
  const ok = (k, m) => {
    const o = (k * M + m) * 3;
    return Number.isFinite(flat[o]) && Number.isFinite(flat[o + 1]) && Number.isFinite(flat[o + 2]);
  };
  const starts = new Uint32Array(n + 1);
  let count = 0;
  for (let k = 0; k < n; k++) {
    starts[k] = count;
    if (k > 0) for (let m = 0; m < M; m++) if (ok(k - 1, m) && ok(k, m)) count++;
  }
  starts[n] = count;
  const xyz = new Float32Array(count * 6);
  let i = 0;
  for (let k = 1; k < n; k++) {
    for (let m = 0; m < M; m++) {
      if (!(ok(k - 1, m) && ok(k, m))) continue;
      const a = ((k - 1) * M + m) * 3;
      const b = (k * M + m) * 3;
      for (let c = 0; c < 3; c++) {
        xyz[i + c] = flat[a + c];
        xyz[i + 3 + c] = flat[b + c];
      }
      i += 6;
    }
  }
  return { xyz, starts };
}

/** Index of the first value of the increasing array `times` at or after `t` (times.length if none). */
function firstAtOrAfter(times, t) {
  let lo = 0;
  let hi = times.length;
  while (lo < hi) {
    const mid = (lo + hi) >> 1;
    if (times[mid] < t) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

/** Index just past the last value of the increasing array `times` at or before `t`. */
function pastLastAtOrBefore(times, t) {
  let lo = 0;
  let hi = times.length;
  while (lo < hi) {
    const mid = (lo + hi) >> 1;
    if (times[mid] <= t) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}

/** A trail: time-ordered line segments of which only those within the time window are drawn. */
class Trail {
  constructor(flat, n, M, material) {
    const { xyz, starts } = trajectorySegments(flat, n, M);
    this.starts = starts;
    const g = new BufferGeometry();
    g.setAttribute("position", new BufferAttribute(xyz, 3));
    this.lines = new LineSegments(g, material);
    this.total = xyz.length / 3; // vertices
  }

  /** Draw the segments whose both ends are samples [a, b) (half-open sample range). */
  show(a, b) {
    const first = a + 1 <= b - 1 ? this.starts[a + 1] : 0;
    const last = a + 1 <= b - 1 ? this.starts[b] : 0;
    this.lines.geometry.setDrawRange(2 * first, 2 * (last - first));
  }

  /** Vertices drawn now. */
  drawn() {
    const r = this.lines.geometry.drawRange;
    return Math.max(Math.min(r.count, this.total - r.start), 0);
  }
}

export class MarkerPanel extends Panel {
  constructor(spec) {
    super(spec, unitScale(spec.unit));
    const where = `panel ${spec.id}`;
    this.times = decodeArray(spec.times, `${where} times`).data;
    const pos = decodeArray(spec.positions, `${where} positions`);
    if (pos.shape.length !== 3 || pos.shape[2] !== 3) throw new Error(`${where}: positions of shape [${pos.shape}]`);
    const [n, M] = pos.shape;
    this.positions = pos.data;
    this.nMarkers = M;
    const fitted = decodeArray(spec.fitted, `${where} fitted`);
    if (fitted && (fitted.shape[0] !== n || fitted.shape[2] !== 3)) throw new Error(`${where}: fitted of shape [${fitted.shape}]`);
    this.growRaw(this.positions);
    if (fitted) this.growRaw(fitted.data);
    const size = this.rawSize();
    const radius = size * 0.008;
    /** Half-width (s) of the time window the trails are drawn in; Infinity = the whole take. */
    this.trailSeconds = Infinity;

    this.trails = { trajectory: new Trail(this.positions, n, M,
      new LineBasicMaterial({ color: TRAJECTORY, transparent: true, opacity: 0.45, depthWrite: false })) };
    if (fitted) this.trails.fitted = new Trail(fitted.data, n, fitted.shape[1], new LineBasicMaterial({ color: FITTED }));
    for (const trail of Object.values(this.trails)) this.inner.add(trail.lines);

    // the knots in time order, their matrices copied per frame into the mesh's first instances
    const knots = [];
    for (const k of spec.knots || []) {
      (k.positions || []).forEach((p, i) => {
        if (p.every(Number.isFinite) && Number.isFinite(k.times[i])) knots.push({ t: k.times[i], p });
      });
    }
    knots.sort((a, b) => a.t - b.t);
    this.knotTimes = Float64Array.from(knots, (k) => k.t);
    this.knotMatrices = new Float32Array(16 * knots.length);
    this.knots = null;
    if (knots.length) {
      const m = new Matrix4();
      knots.forEach((k, i) => m.makeTranslation(k.p[0], k.p[1], k.p[2]).toArray(this.knotMatrices, 16 * i));
      this.knots = new InstancedMesh(new SphereGeometry(radius * 1.8, 14, 10), new MeshLambertMaterial({ color: KNOT }), knots.length);
      this.knots.frustumCulled = false; // which knots are drawn changes every frame
      this.knots.name = `${spec.id} knots`;
      this.inner.add(this.knots);
    }

    this.markers = new InstancedMesh(new SphereGeometry(radius, 14, 10), new MeshLambertMaterial({ color: MARKER }), M);
    this.markers.frustumCulled = false;
    this.markers.name = `${spec.id} markers`;
    this.inner.add(this.markers);
    this.label = textSprite(spec.name, size * unitScale(spec.unit) * 0.04);
    this.root.add(this.label);
    this.matrix = new Matrix4();
    this.current = -1;
  }

  /** What the side column's key lists for this panel: [[what, colour, shape], ...]. */
  legendItems() {
    const items = [["markers (this frame)", MARKER, "dot"], ["trajectories", TRAJECTORY, "line"]];
    if (this.trails.fitted) items.push(["fitted pieces (filter)", FITTED, "line"]);
    if (this.knots) items.push(["knots (piece boundaries)", KNOT, "dot"]);
    return items;
  }

  update(t) {
    const k = sampleAt(this.times, t);
    this.current = k;
    const M = this.nMarkers;
    const P = this.positions;
    for (let m = 0; m < M; m++) {
      const o = (k * M + m) * 3;
      if (Number.isFinite(P[o]) && Number.isFinite(P[o + 1]) && Number.isFinite(P[o + 2])) {
        this.matrix.makeTranslation(P[o], P[o + 1], P[o + 2]);
      } else {
        this.matrix.makeScale(0, 0, 0); // missing at this frame: not drawn
      }
      this.markers.setMatrixAt(m, this.matrix);
    }
    this.markers.instanceMatrix.needsUpdate = true;
    this.showTrails(t);
  }

  /** Draw the trails and knots within `trailSeconds` of time `t` (all of them for Infinity). */
  showTrails(t) {
    const w = this.trailSeconds;
    const all = !Number.isFinite(w);
    const a = all ? 0 : firstAtOrAfter(this.times, t - w);
    const b = all ? this.times.length : pastLastAtOrBefore(this.times, t + w);
    for (const trail of Object.values(this.trails)) trail.show(a, b);
    if (this.knots) {
      const i0 = all ? 0 : firstAtOrAfter(this.knotTimes, t - w);
      const i1 = all ? this.knotTimes.length : pastLastAtOrBefore(this.knotTimes, t + w);
      const count = Math.max(i1 - i0, 0);
      if (count) this.knots.instanceMatrix.array.set(this.knotMatrices.subarray(16 * i0, 16 * i1));
      this.knots.count = count;
      this.knots.instanceMatrix.needsUpdate = true;
    }
  }

  /** Test hook: vertices of each trail and knots drawn now. */
  drawnTrail() {
    const out = { knots: this.knots ? this.knots.count : 0 };
    for (const [name, trail] of Object.entries(this.trails)) out[name] = trail.drawn();
    return out;
  }

  /** World positions of the markers at the current frame (null where missing). */
  points() {
    const k = Math.max(this.current, 0);
    const M = this.nMarkers;
    this.root.updateWorldMatrix(true, true);
    const out = [];
    for (let m = 0; m < M; m++) {
      const o = (k * M + m) * 3;
      const v = new Vector3(this.positions[o], this.positions[o + 1], this.positions[o + 2]);
      out.push(Number.isFinite(v.x + v.y + v.z) ? v.applyMatrix4(this.inner.matrixWorld) : null);
    }
    return out;
  }
}
