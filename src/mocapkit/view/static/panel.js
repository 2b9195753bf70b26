// What every panel of the 3-D view shares: a root group placed by the layout, an inner group that turns
// the file's axes upright (z-up data rotated so z points up the screen) and scales its unit to cm, the
// bounding box of everything the panel draws over all frames, and text labels as sprites.

import { Box3, CanvasTexture, Group, SRGBColorSpace, Sprite, SpriteMaterial, Vector3 } from "three";

/** Length units of marker files -> factor to cm (unknown units are drawn as they are). */
const TO_CM = { mm: 0.1, cm: 1, m: 100, dm: 10, in: 2.54, inch: 2.54, ft: 30.48 };

export function unitScale(unit) {
  return TO_CM[String(unit || "").toLowerCase()] ?? 1;
}

export class Panel {
  /**
   * @param {object} spec  the scene's panel dict
   * @param {number} scale  file unit -> scene unit factor
   */
  constructor(spec, scale = 1) {
    this.id = spec.id;
    this.spec = spec;
    this.root = new Group();
    this.root.name = spec.id;
    this.inner = new Group();
    if (spec.up === "z") this.inner.rotation.x = -Math.PI / 2; // (x, y, z) -> (x, z, -y)
    this.inner.scale.setScalar(scale);
    this.inner.updateMatrix();
    this.root.add(this.inner);
    this.rawBox = new Box3();
  }

  /** Grow the raw (file-coordinate) box by the finite points of a flat xyz array. */
  growRaw(flat) {
    const b = this.rawBox;
    for (let i = 0; i + 2 < flat.length; i += 3) {
      const x = flat[i];
      const y = flat[i + 1];
      const z = flat[i + 2];
      if (Number.isFinite(x) && Number.isFinite(y) && Number.isFinite(z)) {
        if (x < b.min.x) b.min.x = x;
        if (y < b.min.y) b.min.y = y;
        if (z < b.min.z) b.min.z = z;
        if (x > b.max.x) b.max.x = x;
        if (y > b.max.y) b.max.y = y;
        if (z > b.max.z) b.max.z = z;
      }
    }
  }

  /** The diagonal of the raw box (file units), 1 when empty. */
  rawSize() {
    if (this.rawBox.isEmpty()) return 1;
    return Math.max(this.rawBox.getSize(new Vector3()).length(), 1e-6);
  }

  /** The box in the panel's upright coordinates (before the layout's offset). */
  localBox() {
    if (this.rawBox.isEmpty()) return new Box3(new Vector3(-1, -1, -1), new Vector3(1, 1, 1));
    return this.rawBox.clone().applyMatrix4(this.inner.matrix);
  }

  /**
   * Place the panel's name label (if any) above its upright box `box`, `row` label heights higher;
   * `height`: the label's height in scene units (default: the size it was made with).
   */
  placeLabel(box, row = 0, height = null) {
    if (!this.label) return;
    if (!this.labelScale) this.labelScale = this.label.scale.clone();
    this.label.scale.copy(this.labelScale).multiplyScalar(height === null ? 1 : height / this.labelScale.y);
    const h = box.getSize(new Vector3()).length();
    const y = box.max.y + h * 0.05 + row * this.label.scale.y * 1.3;
    this.label.position.set((box.min.x + box.max.x) / 2, y, (box.min.z + box.max.z) / 2);
  }

  /** Hook: draw the panel at timeline time `t` (seconds). */
  update(_t) {}

  /** Hook: the world positions of the panel's points at the current frame (null = missing). */
  points() { return []; }
}

/**
 * A text label that always faces the camera.
 * @param {string} text
 * @param {number} height  height of the label in scene units
 * @param {string} color
 */
export function textSprite(text, height, color = "#d8dde6") {
  const canvas = document.createElement("canvas");
  const px = 48;
  const ctx = canvas.getContext("2d");
  ctx.font = `${px}px sans-serif`;
  const w = Math.ceil(ctx.measureText(text).width) + 16;
  canvas.width = w;
  canvas.height = px + 16;
  ctx.font = `${px}px sans-serif`;
  ctx.fillStyle = color;
  ctx.textBaseline = "middle";
  ctx.fillText(text, 8, canvas.height / 2);
  const texture = new CanvasTexture(canvas);
  texture.colorSpace = SRGBColorSpace;
  const sprite = new Sprite(new SpriteMaterial({ map: texture, transparent: true, depthWrite: false }));
  sprite.scale.set((height * canvas.width) / canvas.height, height, 1);
  return sprite;
}
