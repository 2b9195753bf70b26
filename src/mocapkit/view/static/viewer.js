// mocapkit view: loads /scene.json, builds one panel per scene panel in a three.js view, runs the
// timeline, and fills in the test hooks of window.mocapkitView (see hooks.js and docs/viewer.md).

import {
  AmbientLight, Box3, Color, DirectionalLight, GridHelper, OrthographicCamera, PerspectiveCamera, Scene, Vector3,
  WebGLRenderer,
} from "three";
import { OrbitControls } from "three/addons/OrbitControls.js";
import { decodeArray } from "./arrays.js";
import { drawLegend } from "./colors.js";
import { ImuPanel } from "./imu.js";
import { MarkerPanel } from "./markers.js";
import { SkeletonPanel } from "./skeleton.js";
import { Timeline } from "./timeline.js";

const BACKGROUND = "#1d2026";
/** Follow by default when a skeleton's root travels more than this many body heights over the take. */
const FOLLOW_TRAVEL = 1.5;
const FLOOR = "#2c313b";
const FLOOR_AXES = "#3a414e";
/** The default view: from the front, a little from above and from the right (unit vector towards the camera). */
const VIEW_DIR = new Vector3(0.3, 0.35, 1).normalize();
/** Side by side, panel after panel along the view's horizontal right vector, scaled to one unit along x: every
 * panel is then at the same distance from the default camera (drawn at the same scale). */
const ACROSS = new Vector3(VIEW_DIR.z, 0, -VIEW_DIR.x).divideScalar(VIEW_DIR.z);

/** 1, 2 or 5 times a power of ten, nearest (in ratio) to `v` > 0. */
function niceStep(v) {
  const p = 10 ** Math.floor(Math.log10(v));
  const f = v / p;
  return p * (f < 1.5 ? 1 : f < 3.5 ? 2 : f < 7.5 ? 5 : 10);
}

/** `v` rounded to a multiple of `step`. */
function snap(v, step) {
  return Math.round(v / step) * step;
}
const hooks = window.mocapkitView;

function status(text, isError = false) {
  const el = document.getElementById("status");
  el.textContent = text;
  el.classList.toggle("error", isError);
}

function listItems(id, items) {
  const ul = document.getElementById(id);
  ul.replaceChildren(...items.map((node) => {
    const li = document.createElement("li");
    li.append(...(Array.isArray(node) ? node : [node]));
    return li;
  }));
}

/** The file list of the header: one item per panel, with its kind and role. */
function describeFiles(scene) {
  return scene.panels.map((p) => {
    const b = document.createElement("b");
    b.textContent = p.name;
    const what = p.kind === "skeleton" ? `skeleton, ${p.role || "original"}` : p.kind;
    const extra = p.kind === "skeleton" && p.max_error !== null && p.max_error !== undefined
      ? `, max error ${p.max_error.toFixed(2)} cm` + (p.bound !== null && p.bound !== undefined ? ` (bound ${p.bound} cm)` : "")
      : "";
    return [b, ` (${what}${extra})`];
  });
}

class View {
  constructor(scene) {
    this.scene = scene;
    this.pending = false; // an animation frame is requested
    const host = document.getElementById("view3d");
    this.renderer = new WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(devicePixelRatio);
    this.renderer.setClearColor(new Color(BACKGROUND), 1);
    host.append(this.renderer.domElement);
    this.world = new Scene();
    this.world.add(new AmbientLight(0xffffff, 1.6));
    const sun = new DirectionalLight(0xffffff, 2.2);
    sun.position.set(0.5, 1, 0.8);
    this.world.add(sun);
    // only IMU bodies: a parallel projection, so that an original and its decode in the same orientation
    // show the same faces wherever they are in the grid
    this.ortho = scene.panels.length > 0 && scene.panels.every((p) => p.kind === "imu");
    this.aspect = 1;
    this.camera = this.ortho ? new OrthographicCamera(-1, 1, 1, -1, 0.1, 1000) : new PerspectiveCamera(40, 1, 0.1, 1000);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener("change", () => this.requestRender());

    const times = decodeArray(scene.timeline.times, "timeline times").data;
    this.times = times;
    const start = times.length ? times[0] : 0;
    const end = times.length ? times[times.length - 1] : 0;
    const plots = document.getElementById("plots");
    this.panels = scene.panels.map((spec) => {
      if (spec.kind === "skeleton") return new SkeletonPanel(spec);
      if (spec.kind === "imu") return new ImuPanel(spec, plots, start, end);
      if (spec.kind === "markers") return new MarkerPanel(spec);
      throw new Error(`panel ${spec.id}: unknown kind ${JSON.stringify(spec.kind)}`);
    });
    for (const p of this.panels) this.world.add(p.root);
    this.skeletons = this.panels.filter((p) => p instanceof SkeletonPanel);
    this.markerPanels = this.panels.filter((p) => p instanceof MarkerPanel);
    this.legends();

    // side by side / overlaid: only a skeleton and its decode have anything to overlay
    this.layoutSelect = document.getElementById("layout");
    this.pairs = this.skeletons.some((p) => p.decoded);
    this.layoutSelect.closest("label").hidden = !this.pairs;
    this.layoutSelect.addEventListener("change", () => { this.layout(); this.drawFrame(this.timeline.frame); });
    // follow: on by default when a skeleton's root travels far for its size
    this.followBox = document.getElementById("follow");
    this.followBox.closest("label").hidden = this.skeletons.length === 0;
    this.followBox.checked = this.skeletons.some((p) => {
      const m = p.measure();
      return m.height > 0 && m.travel > FOLLOW_TRAVEL * m.height;
    });
    this.followBox.addEventListener("change", () => { this.layout(); this.drawFrame(this.timeline.frame); });
    // the trail: how much of the markers' trajectories, curves and knots is drawn
    this.trailSelect = document.getElementById("trail");
    this.trailSelect.closest("label").hidden = this.markerPanels.length === 0;
    this.trailSelect.addEventListener("change", () => { this.setTrail(); this.drawFrame(this.timeline.frame); });
    this.setTrail();
    this.floor = null;

    this.timeline = new Timeline(times, scene.segments, (f) => this.drawFrame(f), () => this.requestRender());
    this.resize();
    this.layout();
    new ResizeObserver(() => { this.resize(); this.render(); }).observe(host);
    this.timeline.setFrame(0);
  }

  /** The side column's legends: the error scale of each decoded skeleton, the colours of each marker panel. */
  legends() {
    const box = document.getElementById("legends");
    for (const p of this.panels) {
      const div = document.createElement("div");
      div.className = "legend";
      div.dataset.panel = p.id;
      const spec = p.spec;
      const title = document.createElement("h2");
      if (p instanceof SkeletonPanel && p.error) {
        const upTo = spec.bound !== null && spec.bound !== undefined ? `the bound, ${spec.bound} cm` : "the largest error";
        title.textContent = `${spec.name}: joint error (cm), 0 to ${upTo}`;
        const canvas = document.createElement("canvas");
        canvas.width = 280;
        canvas.height = 34;
        div.append(title, canvas);
        drawLegend(canvas, p.scaleMax);
      } else if (p instanceof MarkerPanel) {
        title.textContent = spec.name;
        const ul = document.createElement("ul");
        ul.className = "key";
        for (const [what, colour, shape] of p.legendItems()) {
          const li = document.createElement("li");
          const swatch = document.createElement("span");
          swatch.className = `swatch ${shape}`;
          swatch.style.backgroundColor = `#${colour.getHexString()}`;
          li.append(swatch, what);
          ul.append(li);
        }
        div.append(title, ul);
      } else {
        continue;
      }
      box.append(div);
    }
  }

  /** Half-width (s) of the trail window chosen in #trail (Infinity: the whole take). */
  setTrail() {
    const v = this.trailSelect.value;
    const seconds = v === "all" ? Infinity : Number(v);
    for (const p of this.markerPanels) p.trailSeconds = seconds;
  }

  /** Whether the camera follows the skeletons. */
  get following() {
    return this.skeletons.length > 0 && this.followBox.checked;
  }

  /**
   * Place the panels side by side (each offset by the widths before it, along ACROSS) or overlaid, and frame
   * the camera on all of them; when following, skeletons are one body apart and the camera is framed
   * on their current poses. A floor grid is laid under the skeletons.
   */
  layout() {
    const side = !(this.pairs && this.layoutSelect.value === "overlay");
    const follow = this.following;
    const imus = this.panels.filter((p) => p instanceof ImuPanel);
    for (const p of imus) p.arrange(this.aspect / (side ? imus.length : 1));
    const body = Math.max(0, ...this.skeletons.map((p) => p.measure().size));
    let x = 0;
    let followX = 0;
    const all = new Box3();
    const paths = new Box3(); // the skeletons' boxes over the take, as placed
    for (const p of this.skeletons) p.setJointSize(follow ? 0.012 : null);
    this.panels.forEach((p, i) => {
      const box = p.localBox();
      p.placeLabel(box, side ? 0 : i); // overlaid: the labels stacked
      const width = box.max.x - box.min.x;
      const gap = 0.15 * Math.max(width, box.max.y - box.min.y);
      let dx = side ? x - box.min.x : 0;
      if (follow && p instanceof SkeletonPanel) {
        dx = side ? followX : 0;
        followX += body;
      }
      p.root.position.copy(ACROSS).multiplyScalar(dx);
      if (p instanceof SkeletonPanel) paths.union(box.clone().translate(p.root.position));
      if (side) x = Math.max(x, dx + box.max.x + gap);
      all.union(box.clone().translate(p.root.position));
      if (p.label) all.expandByPoint(p.label.position.clone().add(p.root.position).setY(p.label.position.y + p.label.scale.y));
    });
    if (all.isEmpty()) all.set(new Vector3(-100, -100, -100), new Vector3(100, 100, 100)); // nothing to draw
    this.world.updateMatrixWorld(true);
    this.placeFloor(paths, body, follow ? 2 * body : 0.2 * body);
    if (follow) {
      this.followed = this.skeletons.length;
      this.followLabels();
      this.frameFollow();
    } else {
      this.followed = 0;
      this.frameCamera(all);
    }
  }

  /**
   * A floor grid under the skeletons' paths, `margin` wider on every side (depth cues, and travel shows when
   * the camera follows).
   */
  placeFloor(paths, body, margin) {
    if (this.floor) {
      this.world.remove(this.floor);
      this.floor.geometry.dispose();
      this.floor.material.dispose();
      this.floor = null;
    }
    if (!paths || paths.isEmpty() || !(body > 0)) return;
    const cell = niceStep(body / 3);
    const extent = Math.max(paths.max.x - paths.min.x, paths.max.z - paths.min.z) + 2 * margin;
    const divisions = Math.min(Math.ceil(extent / cell), 400);
    this.floor = new GridHelper(divisions * cell, divisions, FLOOR_AXES, FLOOR);
    this.floor.position.set(snap((paths.min.x + paths.max.x) / 2, cell), paths.min.y, snap((paths.min.z + paths.max.z) / 2, cell));
    this.floor.name = "floor";
    this.world.add(this.floor);
  }

  /** The centre (world) of the followed skeletons' joints at the current frame; null if none is drawn. */
  followCentre() {
    const box = new Box3();
    for (const p of this.skeletons) {
      const b = p.currentBox();
      if (!b.isEmpty()) box.union(b.translate(p.root.position));
    }
    return box.isEmpty() ? null : box.getCenter(new Vector3());
  }

  /** Put the followed skeletons' labels above their current poses. */
  followLabels() {
    const side = !(this.pairs && this.layoutSelect.value === "overlay");
    this.skeletons.forEach((p, i) => {
      const box = p.currentBox();
      if (!box.isEmpty()) p.placeLabel(box, side ? 0 : i, p.measure().height * 0.05);
    });
  }

  /** Frame the camera on about one body around the skeletons' current centre (a default view). */
  frameFollow() {
    const centre = this.followCentre() || new Vector3();
    const m = this.skeletons.map((p) => p.measure());
    const height = Math.max(...m.map((v) => v.height), 1e-3);
    const size = Math.max(...m.map((v) => v.size), height);
    const side = !(this.pairs && this.layoutSelect.value === "overlay");
    const spread = side ? (this.skeletons.length - 1) * size : 0;
    const box = new Box3().setFromCenterAndSize(
      centre, new Vector3(spread + height * 0.8, height * 1.25, Math.abs(ACROSS.z) * spread + height * 0.8));
    this.frameCamera(box);
    this.followAt = centre;
  }

  /** Move the camera with the skeletons: target and position shift by the centre's move since last frame. */
  follow() {
    const centre = this.followCentre();
    if (!centre) return;
    const delta = centre.clone().sub(this.followAt);
    this.camera.position.add(delta);
    this.controls.target.add(delta);
    this.followAt = centre;
  }

  /** Put the camera in front of `box` (slightly from above and the side) so that all of it is seen. */
  frameCamera(box) {
    const center = box.getCenter(new Vector3());
    const dir = VIEW_DIR.clone();
    const up = new Vector3(0, 1, 0);
    const right = new Vector3().crossVectors(up, dir).normalize();
    const camUp = new Vector3().crossVectors(dir, right).normalize();
    if (this.ortho) {
      this.frameParallel(box, center, dir, right, camUp);
      return;
    }
    const tanV = Math.tan((this.camera.fov * Math.PI) / 360);
    const tanH = tanV * this.camera.aspect;
    let distance = 0;
    for (let c = 0; c < 8; c++) {
      const corner = new Vector3(c & 1 ? box.max.x : box.min.x, c & 2 ? box.max.y : box.min.y, c & 4 ? box.max.z : box.min.z);
      const r = corner.sub(center);
      const depth = r.dot(dir); // towards the camera
      distance = Math.max(distance, Math.abs(r.dot(right)) / tanH + depth, Math.abs(r.dot(camUp)) / tanV + depth);
    }
    distance = Math.max(distance * 1.08, 1e-3);
    const size = box.getSize(new Vector3()).length();
    this.camera.position.copy(center).addScaledVector(dir, distance);
    this.camera.near = Math.max(distance / 200, 1e-4);
    this.camera.far = distance * 4 + size * 4;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(center);
    this.controls.update();
    this.framedBox = box;
  }

  /** frameCamera for the parallel projection: the view's half height fits `box` seen along `dir`. */
  frameParallel(box, center, dir, right, camUp) {
    let halfW = 0;
    let halfH = 0;
    for (let c = 0; c < 8; c++) {
      const r = new Vector3(c & 1 ? box.max.x : box.min.x, c & 2 ? box.max.y : box.min.y, c & 4 ? box.max.z : box.min.z).sub(center);
      halfW = Math.max(halfW, Math.abs(r.dot(right)));
      halfH = Math.max(halfH, Math.abs(r.dot(camUp)));
    }
    const half = Math.max(halfH, halfW / this.aspect, 1e-3) * 1.08;
    // the distance does not change the scale: far enough that the box stays in front as the view orbits
    const size = Math.max(box.getSize(new Vector3()).length(), 2 * half);
    Object.assign(this.camera, { left: -half * this.aspect, right: half * this.aspect, top: half, bottom: -half, zoom: 1 });
    this.camera.position.copy(center).addScaledVector(dir, size);
    this.camera.near = size * 0.05;
    this.camera.far = size * 2.5;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(center);
    this.controls.update();
    this.framedBox = box;
  }

  resize() {
    const host = this.renderer.domElement.parentElement;
    const w = Math.max(host.clientWidth, 1);
    const h = Math.max(host.clientHeight, 1);
    this.renderer.setSize(w, h, false);
    const aspect = w / h;
    const changed = Math.abs(aspect - this.aspect) > 1e-6;
    this.aspect = aspect;
    if (!this.ortho) this.camera.aspect = aspect;
    this.camera.updateProjectionMatrix();
    if (!this.framedBox) return;
    if (changed && this.panels.some((p) => p instanceof ImuPanel)) this.layout(); // the grid fits the view's shape
    else if (this.followed) this.frameFollow();
    else this.frameCamera(this.framedBox);
  }

  drawFrame(f) {
    const t = this.times.length ? this.times[f] : 0;
    for (const p of this.panels) p.update(t);
    if (this.followed) {
      this.followLabels();
      this.follow();
    }
    this.render();
  }

  render() {
    this.renderer.render(this.world, this.camera);
  }

  /** Render on the next animation frame; keep going while the timeline plays. */
  requestRender() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame((now) => {
      this.pending = false;
      if (!this.timeline.tick(now)) this.render();
      if (this.timeline.playing) this.requestRender();
    });
  }

  /** [x, y] CSS pixels (page viewport) of a panel's points at the current frame; null where missing. */
  screenPositions(panelId) {
    const panel = this.panels.find((p) => p.id === panelId);
    if (!panel) throw new Error(`no panel ${panelId}`);
    this.camera.updateMatrixWorld();
    const rect = this.renderer.domElement.getBoundingClientRect();
    return panel.points().map((v) => {
      if (!v) return null;
      const p = v.clone().project(this.camera);
      return [rect.left + ((p.x + 1) / 2) * rect.width, rect.top + ((1 - p.y) / 2) * rect.height];
    });
  }
}

async function main() {
  const response = await fetch("/scene.json");
  if (!response.ok) throw new Error(`/scene.json: HTTP ${response.status}`);
  const scene = await response.json();
  if (scene.mocapkit_view !== 1) throw new Error(`/scene.json: schema ${scene.mocapkit_view}, this page reads 1`);
  document.title = `mocapkit view: ${scene.title}`;
  document.getElementById("title").textContent = scene.title;
  listItems("files", describeFiles(scene));
  listItems("notes", (scene.notes || []).map(String));
  const view = new View(scene);
  Object.assign(hooks, {
    background: BACKGROUND,
    frames: view.times.length,
    setFrame: (i) => { view.timeline.pause(); view.timeline.setFrame(i); return view.timeline.frame; },
    frame: () => view.timeline.frame,
    jointScreenPositions: (panelId) => view.screenPositions(panelId),
    panels: () => view.panels.map((p) => ({ id: p.id, kind: p.spec.kind })),
    drawnTrail: (panelId) => {
      const panel = view.markerPanels.find((p) => p.id === panelId);
      if (!panel) throw new Error(`no marker panel ${panelId}`);
      return panel.drawnTrail();
    },
  });
  status("");
  hooks.ready = true;
}

main().catch((err) => {
  hooks.errors.push(String((err && err.stack) || err));
  status(`The scene could not be shown: ${err && err.message ? err.message : err}`, true);
});
