// A skeleton panel: joints as small spheres coloured by their error, bones as lines parent -> child.

import {
  Box3, BufferAttribute, BufferGeometry, Color, InstancedMesh, LineBasicMaterial, LineSegments, Matrix4,
  MeshLambertMaterial, SphereGeometry, Vector3,
} from "three";
import { decodeArray, sampleAt } from "./arrays.js";
import { PLAIN_JOINT, errorColor } from "./colors.js";
import { Panel, textSprite } from "./panel.js";

const ORIGINAL_BONES = new Color("#c9d1dc");
const DECODED_BONES = new Color("#f28e2b");

export class SkeletonPanel extends Panel {
  constructor(spec) {
    super(spec, 1); // positions are in cm
    const where = `panel ${spec.id}`;
    this.times = decodeArray(spec.times, `${where} times`).data;
    const pos = decodeArray(spec.positions, `${where} positions`);
    if (pos.shape.length !== 3 || pos.shape[2] !== 3) throw new Error(`${where}: positions of shape [${pos.shape}]`);
    this.positions = pos.data;
    this.nJoints = pos.shape[1];
    this.nFrames = pos.shape[0];
    const err = decodeArray(spec.error, `${where} error`);
    this.error = err ? err.data : null;
    /** The colour scale's maximum (cm): the bound when the file says, else the largest error. */
    this.scaleMax = spec.bound ?? spec.max_error ?? 0;
    this.decoded = spec.role === "decoded";
    this.parents = spec.parents;
    this.growRaw(this.positions);
    const size = this.rawSize();
    this.radius = size * (this.decoded ? 0.011 : 0.009);
    /** Scale of the joints' spheres (setJointSize). */
    this.jointScale = 1;

    const J = this.nJoints;
    this.joints = new InstancedMesh(new SphereGeometry(this.radius, 14, 10), new MeshLambertMaterial(), J);
    this.joints.frustumCulled = false; // instances move every frame
    this.joints.name = `${spec.id} joints`;
    for (let j = 0; j < J; j++) this.joints.setColorAt(j, PLAIN_JOINT);
    this.inner.add(this.joints);

    this.bonePairs = [];
    for (let j = 0; j < J; j++) if (this.parents[j] >= 0) this.bonePairs.push([this.parents[j], j]);
    const geometry = new BufferGeometry();
    this.boneXYZ = new Float32Array(this.bonePairs.length * 6);
    geometry.setAttribute("position", new BufferAttribute(this.boneXYZ, 3));
    this.bones = new LineSegments(geometry, new LineBasicMaterial({ color: this.decoded ? DECODED_BONES : ORIGINAL_BONES }));
    this.bones.frustumCulled = false;
    this.inner.add(this.bones);

    if (this.decoded) {
      // drawn after the originals: where both are at the same depth (overlaid, no error) the decode shows
      this.joints.renderOrder = 1;
      this.bones.renderOrder = 1;
    }
    this.label = textSprite(`${spec.name} (${spec.role || "skeleton"})`, size * 0.04);
    this.root.add(this.label);
    this.matrix = new Matrix4();
    this.color = new Color();
    this.current = -1;
  }

  /**
   * Sizes in upright scene units (cm): `height`, the median over frames of the vertical extent of the
   * joints; `size`, the median diagonal of a frame's box of joints; `travel`, the diagonal of the
   * horizontal box of the root joint's path over the take.
   */
  measure() {
    if (this.measured) return this.measured;
    const J = this.nJoints;
    const n = this.nFrames;
    const P = this.positions;
    const up = this.spec.up === "z" ? 2 : 1;
    const across = up === 2 ? 1 : 2;
    const heights = [];
    const sizes = [];
    const step = Math.max(1, Math.floor(n / 500));
    const lo = [0, 0, 0];
    const hi = [0, 0, 0];
    for (let k = 0; k < n; k += step) {
      lo.fill(Infinity);
      hi.fill(-Infinity);
      for (let j = 0; j < J; j++) {
        const o = (k * J + j) * 3;
        if (!(Number.isFinite(P[o]) && Number.isFinite(P[o + 1]) && Number.isFinite(P[o + 2]))) continue;
        for (let c = 0; c < 3; c++) {
          lo[c] = Math.min(lo[c], P[o + c]);
          hi[c] = Math.max(hi[c], P[o + c]);
        }
      }
      if (!(hi[0] >= lo[0])) continue;
      heights.push(hi[up] - lo[up]);
      sizes.push(Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]));
    }
    const median = (v) => (v.length ? v.sort((a, b) => a - b)[v.length >> 1] : 0);
    const root = Math.max(this.parents.indexOf(-1), 0);
    const path = [[Infinity, -Infinity], [Infinity, -Infinity]];
    for (let k = 0; k < n; k++) {
      const o = (k * J + root) * 3;
      const a = P[o];
      const b = P[o + across];
      if (!(Number.isFinite(a) && Number.isFinite(b))) continue;
      path[0][0] = Math.min(path[0][0], a);
      path[0][1] = Math.max(path[0][1], a);
      path[1][0] = Math.min(path[1][0], b);
      path[1][1] = Math.max(path[1][1], b);
    }
    const travel = path[0][1] >= path[0][0] ? Math.hypot(path[0][1] - path[0][0], path[1][1] - path[1][0]) : 0;
    const scale = this.inner.scale.x;
    this.measured = { height: median(heights) * scale, size: median(sizes) * scale, travel: travel * scale };
    return this.measured;
  }

  /** Joints drawn `fraction` of a body size across (null: their size relative to the whole take). */
  setJointSize(fraction) {
    const size = this.measure().size;
    this.jointScale = fraction === null || !(size > 0) ? 1 : (fraction * size * (this.decoded ? 1.2 : 1)) / this.radius;
  }

  /** The box of the joints at the current frame in the panel's upright coordinates (empty if none). */
  currentBox() {
    const box = new Box3();
    const k = Math.max(this.current, 0);
    const J = this.nJoints;
    const v = new Vector3();
    for (let j = 0; j < J; j++) {
      const o = (k * J + j) * 3;
      v.set(this.positions[o], this.positions[o + 1], this.positions[o + 2]);
      if (Number.isFinite(v.x + v.y + v.z)) box.expandByPoint(v.applyMatrix4(this.inner.matrix));
    }
    return box;
  }

  update(t) {
    const k = sampleAt(this.times, t);
    this.current = k;
    const J = this.nJoints;
    const P = this.positions;
    const base = k * J * 3;
    for (let j = 0; j < J; j++) {
      const x = P[base + 3 * j];
      const y = P[base + 3 * j + 1];
      const z = P[base + 3 * j + 2];
      if (Number.isFinite(x) && Number.isFinite(y) && Number.isFinite(z)) {
        this.matrix.makeScale(this.jointScale, this.jointScale, this.jointScale).setPosition(x, y, z);
      } else {
        this.matrix.makeScale(0, 0, 0);
      }
      this.joints.setMatrixAt(j, this.matrix);
      if (this.error) this.joints.setColorAt(j, errorColor(this.error[k * J + j], this.scaleMax, this.color));
    }
    this.joints.instanceMatrix.needsUpdate = true;
    if (this.joints.instanceColor) this.joints.instanceColor.needsUpdate = true;
    const B = this.boneXYZ;
    this.bonePairs.forEach(([a, b], i) => {
      for (let c = 0; c < 3; c++) {
        B[6 * i + c] = P[base + 3 * a + c];
        B[6 * i + 3 + c] = P[base + 3 * b + c];
      }
    });
    this.bones.geometry.attributes.position.needsUpdate = true;
  }

  /** World positions of the joints at the current frame (null for a missing joint). */
  points() {
    const out = [];
    const k = Math.max(this.current, 0);
    const J = this.nJoints;
    this.root.updateWorldMatrix(true, true);
    for (let j = 0; j < J; j++) {
      const o = (k * J + j) * 3;
      const v = new Vector3(this.positions[o], this.positions[o + 1], this.positions[o + 2]);
      out.push(Number.isFinite(v.x + v.y + v.z) ? v.applyMatrix4(this.inner.matrixWorld) : null);
    }
    return out;
  }
}
