// An IMU panel: per sensor a rotating body for the original and one for the decode, side by side and
// labelled, the sensors in a grid shaped to the view, and (in the side column) each sensor's angle
// error over time.

import {
  AxesHelper, Box3, BoxGeometry, EdgesGeometry, Group, LineBasicMaterial, LineSegments, Mesh,
  MeshLambertMaterial, Vector3,
} from "three";
import { decodeArray, sampleAt } from "./arrays.js";
import { ErrorPlot } from "./errorplot.js";
import { Panel, textSprite } from "./panel.js";

/** Body size (cm): long along x, medium along y, thin along z, so every axis reads at a glance. */
const BODY = [24, 14, 6];
/** Distance between the original's and the decode's body of a sensor, and between rows of the grid. */
const COLUMN = 50;
const ROW = 48;
/** Space between two sensors of a grid row, beyond their bodies. */
const GAP = 16;
/** Half the space a body may take as it turns. */
const REACH = BODY[0] * 0.9;
/** Face colours in BoxGeometry's face order: +x, -x, +y, -y, +z, -z. */
const FACES = ["#e05252", "#7a2c2c", "#4cbb5e", "#2b6634", "#4c7ee0", "#2b4279"];

function makeBody(decoded) {
  const body = new Group();
  const materials = FACES.map((c) => new MeshLambertMaterial({ color: c }));
  const box = new Mesh(new BoxGeometry(...BODY), materials);
  body.add(box);
  body.add(new AxesHelper(BODY[0] * 0.85));
  if (decoded) {
    body.add(new LineSegments(new EdgesGeometry(box.geometry), new LineBasicMaterial({ color: "#f28e2b" })));
  }
  return body;
}

export class ImuPanel extends Panel {
  /**
   * @param {object} spec  the scene's imu panel
   * @param {HTMLElement} plots  the side column's container for the error plots
   * @param {number} start  timeline start (s)
   * @param {number} end    timeline end (s)
   */
  constructor(spec, plots, start, end) {
    super(spec, 1);
    this.sensors = [];
    this.plots = [];
    const section = document.createElement("section");
    section.className = "imu-plots";
    section.dataset.panel = spec.id;
    const h2 = document.createElement("h2");
    h2.textContent = `${spec.name}: angle error`;
    section.append(h2);
    plots.append(section);
    (spec.sensors || []).forEach((sensor) => {
      // one cell of bodies per sensor, then its error plot in the side column
      const where = `panel ${spec.id} sensor ${sensor.name}`;
      const quats = { original: decodeArray(sensor.original, `${where} original`), decoded: decodeArray(sensor.decoded, `${where} decoded`) };
      const times = decodeArray(sensor.times, `${where} times`).data;
      const row = new Group(); // one grid cell, placed by arrange()
      this.root.add(row);
      const entry = { name: sensor.name, times, bodies: [], row };
      const name = textSprite(sensor.name, 5);
      name.position.set(COLUMN / 2, 18, 0);
      row.add(name);
      ["original", "decoded"].forEach((role, c) => {
        const q = quats[role];
        if (!q) return;
        if (q.shape.length !== 2 || q.shape[1] !== 4) throw new Error(`${where}: ${role} of shape [${q.shape}]`);
        const slot = new Group();
        slot.position.set(c * COLUMN, 0, 0);
        const frame = new Group(); // the recording's axes turned upright
        if (spec.up === "z") frame.rotation.x = -Math.PI / 2;
        const body = makeBody(role === "decoded");
        frame.add(body);
        slot.add(frame);
        const label = textSprite(role === "decoded" ? "decoded" : "original", 4.5, role === "decoded" ? "#f28e2b" : "#d8dde6");
        label.position.set(0, -16, 0);
        slot.add(label);
        row.add(slot);
        entry.bodies.push({ body, q: q.data, slot });
      });
      this.sensors.push(entry);
      const present = entry.bodies.map((b) => b.slot.position.x);
      if (present.length) name.position.x = (Math.min(...present) + Math.max(...present)) / 2;
      const err = decodeArray(sensor.error_deg, `${where} error_deg`);
      const kf = decodeArray(sensor.keyframes, `${where} keyframes`);
      if (!err && !(kf && kf.data.length)) {
        const p = document.createElement("p");
        p.className = "muted";
        p.textContent = `${sensor.name}: ${quats.decoded ? "no original to compare with" : "no decode (original only)"}`;
        section.append(p);
        return;
      }
      const canvas = document.createElement("canvas");
      canvas.className = "error-plot";
      canvas.dataset.panel = spec.id;
      canvas.dataset.sensor = sensor.name;
      section.append(canvas);
      this.plots.push(new ErrorPlot(canvas, {
        name: sensor.name, times, error: err ? err.data : null, keyframes: kf ? kf.data : null,
        bound: sensor.bound_deg ?? null, maxError: sensor.max_error_deg ?? null,
      }, start, end));
    });
    this.label = textSprite(spec.name, 6);
    this.root.add(this.label);
    this.arrange(1);
  }

  /** Width of one sensor's cell of the grid (its bodies and the gap to the next). */
  cellWidth() {
    const slots = Math.max(1, ...this.sensors.map((s) => s.bodies.length));
    return (slots - 1) * COLUMN + 2 * REACH + GAP;
  }

  /**
   * Lay the sensors out in a grid, row by row in the file's order, with the number of columns that
   * shows the bodies largest in a view of width/height `aspect`.
   */
  arrange(aspect) {
    const n = Math.max(this.sensors.length, 1);
    const cell = this.cellWidth();
    let best = 1;
    let bestFit = 0;
    for (let cols = 1; cols <= n; cols++) {
      const rows = Math.ceil(n / cols);
      const fit = Math.min(aspect / (cols * cell), 1 / (rows * ROW + 12));
      if (fit > bestFit * 1.0001) {
        best = cols;
        bestFit = fit;
      }
    }
    this.columns = best;
    this.sensors.forEach((sensor, s) => sensor.row.position.set((s % best) * cell, -Math.floor(s / best) * ROW, 0));
  }

  localBox() {
    const n = Math.max(this.sensors.length, 1);
    const cols = Math.min(this.columns || 1, n);
    const rows = Math.ceil(n / cols);
    const width = (cols - 1) * this.cellWidth() + (this.cellWidth() - GAP - 2 * REACH);
    return new Box3(new Vector3(-REACH, -(rows - 1) * ROW - 20, -REACH), new Vector3(width + REACH, 22, REACH));
  }

  update(t) {
    for (const sensor of this.sensors) {
      const k = sampleAt(sensor.times, t);
      for (const { body, q } of sensor.bodies) {
        const [w, x, y, z] = [q[4 * k], q[4 * k + 1], q[4 * k + 2], q[4 * k + 3]];
        const ok = [w, x, y, z].every(Number.isFinite) && w * w + x * x + y * y + z * z > 0;
        body.visible = ok;
        if (ok) body.quaternion.set(x, y, z, w).normalize();
      }
    }
    for (const plot of this.plots) plot.draw(t);
  }

  /** World positions of the bodies' centres (original then decoded, per sensor). */
  points() {
    this.root.updateWorldMatrix(true, true);
    const out = [];
    for (const sensor of this.sensors) for (const { slot } of sensor.bodies) out.push(slot.getWorldPosition(new Vector3()));
    return out;
  }
}
