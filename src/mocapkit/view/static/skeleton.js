// A skeleton panel: joints as small spheres coloured by their error, bones as lines parent -> child.

import {
  BufferAttribute, BufferGeometry, Color, InstancedMesh, LineBasicMaterial, LineSegments, Matrix4,
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
        this.matrix.makeTranslation(x, y, z);
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
