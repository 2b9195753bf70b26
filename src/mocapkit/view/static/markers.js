// A marker panel: the markers at the current frame as spheres, their whole trajectories as faint lines,
// the fitted curves of `filter --json` as lines of another colour and the knots as bigger spheres.

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
 * Line segments joining consecutive finite samples of each marker of an (n, M, 3) array.
 * @returns {Float32Array} xyz pairs
 */
function trajectorySegments(flat, n, M) {
  const ok = (k, m) => {
    const o = (k * M + m) * 3;
    return Number.isFinite(flat[o]) && Number.isFinite(flat[o + 1]) && Number.isFinite(flat[o + 2]);
  };
  let count = 0;
  for (let m = 0; m < M; m++) for (let k = 1; k < n; k++) if (ok(k - 1, m) && ok(k, m)) count++;
  const out = new Float32Array(count * 6);
  let i = 0;
  for (let m = 0; m < M; m++) {
    for (let k = 1; k < n; k++) {
      if (!(ok(k - 1, m) && ok(k, m))) continue;
      const a = ((k - 1) * M + m) * 3;
      const b = (k * M + m) * 3;
      out.set([flat[a], flat[a + 1], flat[a + 2], flat[b], flat[b + 1], flat[b + 2]], i);
      i += 6;
    }
  }
  return out;
}

function lines(xyz, material) {
  const g = new BufferGeometry();
  g.setAttribute("position", new BufferAttribute(xyz, 3));
  const l = new LineSegments(g, material);
  return l;
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
    this.growRaw(this.positions);
    if (fitted) this.growRaw(fitted.data);
    const size = this.rawSize();
    const radius = size * 0.008;

    this.inner.add(lines(trajectorySegments(this.positions, n, M),
      new LineBasicMaterial({ color: TRAJECTORY, transparent: true, opacity: 0.45, depthWrite: false })));
    if (fitted) this.inner.add(lines(trajectorySegments(fitted.data, fitted.shape[0], fitted.shape[1]), new LineBasicMaterial({ color: FITTED })));

    const knots = [];
    for (const k of spec.knots || []) for (const p of k.positions || []) if (p.every(Number.isFinite)) knots.push(p);
    if (knots.length) {
      const mesh = new InstancedMesh(new SphereGeometry(radius * 1.8, 14, 10), new MeshLambertMaterial({ color: KNOT }), knots.length);
      const m = new Matrix4();
      knots.forEach((p, i) => mesh.setMatrixAt(i, m.makeTranslation(p[0], p[1], p[2])));
      mesh.name = `${spec.id} knots`;
      this.inner.add(mesh);
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
