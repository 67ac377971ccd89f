// The 3-D view of one entry: its mesh.glb with OrbitControls, framed on the mesh, and the
// pair's two keyframe cameras as wireframe frusta (camera B from report.json's relative_pose).
//
// Frames: report.json is in camera A's OpenCV frame (x right, y down, z forward); the GLB
// stores (x, -y, -z) of it, so the mesh is y up and camera A sits at the origin looking down
// -z, which is also three.js's camera convention.
import * as THREE from "three";
import { GLTFLoader } from "/three/examples/jsm/loaders/GLTFLoader.js";
import { OrbitControls } from "/three/examples/jsm/controls/OrbitControls.js";

const BACKGROUND = 0x1b1f24;
const COLOR_A = 0x4fc3f7;
const COLOR_B = 0xffb74d;

const $ = (id) => document.getElementById(id);
const name = new URLSearchParams(location.search).get("entry") || "";
const entryUrl = (file = "") =>
  `/api/entries/${encodeURIComponent(name)}${file ? "/" + file : ""}`;

const canvas = $("viewer-canvas");
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.gammaOutput = true;  // r111: the texture is sRGB; write sRGB out
const scene = new THREE.Scene();
scene.background = new THREE.Color(BACKGROUND);
const camera = new THREE.PerspectiveCamera(50, 1, 0.01, 1000);
const controls = new OrbitControls(camera, canvas);

// Rendered on demand: after loading, on every orbit step and on resize.
const render = () => renderer.render(scene, camera);
controls.addEventListener("change", render);
function resize() {
  renderer.setSize(window.innerWidth, window.innerHeight);
  camera.aspect = window.innerWidth / window.innerHeight;
  camera.updateProjectionMatrix();
  render();
}
window.addEventListener("resize", resize);

function fail(message) {
  $("viewer-error").textContent = message;
  $("viewer-error").hidden = false;
  $("viewer-info").textContent = "";
  document.body.dataset.error = message;
}

function loadGlb(url) {
  return new Promise((resolve, reject) => new GLTFLoader().load(url, resolve, undefined, (err) => {
    // A failed download is a ProgressEvent on the request; a bad file an Error.
    const status = err && err.target && err.target.status;
    reject(new Error(status ? `${url}: HTTP ${status}` : `${url}: ${err && err.message || err}`));
  }));
}

async function loadReport() {
  const answer = await fetch(entryUrl(), { cache: "no-store" });
  const body = await answer.json().catch(() => ({}));
  if (!answer.ok) throw new Error(`report: ${answer.status}: ${body.error || answer.statusText}`);
  return body;
}

// A camera's wireframe frustum, apex at the origin, looking down -z, y up; `halfW`/`halfH`
// are the image's half extents over the focal length. A small triangle marks the top side.
function frustum(depth, halfW, halfH, color) {
  const w = depth * halfW, h = depth * halfH, z = -depth;
  const c = [[-w, -h, z], [w, -h, z], [w, h, z], [-w, h, z]];
  const segments = [];
  for (let i = 0; i < 4; i++) segments.push([0, 0, 0], c[i], c[i], c[(i + 1) % 4]);
  segments.push([-0.5 * w, h, z], [0, 1.4 * h, z], [0, 1.4 * h, z], [0.5 * w, h, z]);
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute("position", new THREE.Float32BufferAttribute(segments.flat(), 3));
  return new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ color }));
}

// Camera B's pose in the GLB frame from cam_b_from_cam_a (X_b = R X_a + t): its centre is
// C = -R^T t in A's frame; with F = diag(1, -1, -1) (OpenCV <-> GLB axes, F = F^-1) a point q
// in B's GLB-style frame is at F R^T F q + F C.
function cameraBMatrix(R, t) {
  const C = [0, 1, 2].map((i) => -(R[0][i] * t[0] + R[1][i] * t[1] + R[2][i] * t[2]));
  const f = [1, -1, -1];
  const m = (i, j) => f[i] * R[j][i] * f[j];  // (F R^T F)_ij
  return new THREE.Matrix4().set(
    m(0, 0), m(0, 1), m(0, 2), f[0] * C[0],
    m(1, 0), m(1, 1), m(1, 2), f[1] * C[1],
    m(2, 0), m(2, 1), m(2, 2), f[2] * C[2],
    0, 0, 0, 1);
}

// The mesh's extent without its few stray triangles (a depth edge can stretch one far away):
// the 5th to 95th percentile of the vertices on each axis.
function robustBox(object) {
  object.updateMatrixWorld(true);
  const axes = [[], [], []];
  const v = new THREE.Vector3();
  object.traverse((node) => {
    const positions = node.isMesh && node.geometry.attributes.position;
    for (let i = 0; positions && i < positions.count; i++) {
      v.fromBufferAttribute(positions, i).applyMatrix4(node.matrixWorld);
      axes[0].push(v.x); axes[1].push(v.y); axes[2].push(v.z);
    }
  });
  if (!axes[0].length) return new THREE.Box3();
  const at = (sorted, q) => sorted[Math.round(q * (sorted.length - 1))];
  const sorted = axes.map((values) => Float32Array.from(values).sort());
  return new THREE.Box3(new THREE.Vector3(...sorted.map((a) => at(a, 0.05))),
                        new THREE.Vector3(...sorted.map((a) => at(a, 0.95))));
}

// The view camera: on camera A's side of the mesh, a little above it, just far enough back
// that every corner of the box is in view.
function frame(box) {
  const centre = box.getCenter(new THREE.Vector3());
  const toA = centre.clone().negate();
  const back = (toA.lengthSq() > 0 ? toA.normalize() : new THREE.Vector3(0, 0, 1));
  back.add(new THREE.Vector3(0, 0.3, 0)).normalize();
  const right = new THREE.Vector3(0, 1, 0).cross(back).normalize();
  const up = back.clone().cross(right);
  const tanV = Math.tan((camera.fov / 2) * Math.PI / 180);
  const tanH = tanV * camera.aspect;
  let distance = 0;
  for (let i = 0; i < 8; i++) {
    const corner = new THREE.Vector3(i & 1 ? box.max.x : box.min.x, i & 2 ? box.max.y : box.min.y,
                                     i & 4 ? box.max.z : box.min.z).sub(centre);
    distance = Math.max(distance, corner.dot(back) +
      Math.max(Math.abs(corner.dot(up)) / tanV, Math.abs(corner.dot(right)) / tanH));
  }
  distance = Math.max(1.05 * distance, 1e-3);
  camera.position.copy(centre).addScaledVector(back, distance);
  camera.near = distance / 200;
  camera.far = distance * 50;
  camera.updateProjectionMatrix();
  controls.target.copy(centre);
  controls.update();
}

async function main() {
  if (!name) throw new Error("no entry given (viewer.html?entry=NAME)");
  $("viewer-title").textContent = name;
  const [gltf, report] = await Promise.all([
    loadGlb(entryUrl("mesh.glb")),
    loadReport().catch((err) => ({ error: err.message })),
  ]);

  // The texture is the photograph (unlit); both sides, as the mesh is seen from one side only.
  gltf.scene.traverse((node) => { if (node.isMesh) node.material.side = THREE.DoubleSide; });
  scene.add(gltf.scene);
  const box = robustBox(gltf.scene);
  if (box.isEmpty()) throw new Error("mesh.glb holds no geometry");

  // Frusta: camera A at the origin; big enough to see beside the mesh, and beside the baseline.
  const [width, height] = (report.camera && report.camera.image_size) || [640, 480];
  const [fx, fy] = (report.camera && report.camera.fc) || [width, width];
  const halfW = width / 2 / fx, halfH = height / 2 / fy;
  const pose = report.relative_pose;
  const diagonal = box.getSize(new THREE.Vector3()).length();
  let depth = 0.04 * diagonal;
  let info = "";
  if (pose && pose.rotation && pose.translation) {
    const b = cameraBMatrix(pose.rotation, pose.translation);
    const centreB = new THREE.Vector3().setFromMatrixPosition(b);
    depth = Math.max(depth, 0.5 * centreB.length());
    const frustumB = frustum(depth, halfW, halfH, COLOR_B);
    frustumB.matrixAutoUpdate = false;
    frustumB.matrix.copy(b);
    scene.add(frustumB);
    const baseline = new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), centreB]);
    scene.add(new THREE.Line(baseline, new THREE.LineBasicMaterial({ color: 0x888888 })));
  } else {
    info = ` · camera B not drawn (${report.error || "no relative_pose"})`;
  }
  scene.add(frustum(depth, halfW, halfH, COLOR_A));

  const counts = report.counts || {};
  const units = (report.scale && report.scale.units) || "?";
  $("viewer-info").textContent =
    `${counts.mesh_vertices ?? "?"} vertices · ${counts.mesh_triangles ?? "?"} triangles · ` +
    `units: ${units} · drag to orbit, wheel to zoom` + info;
  // The legend: a coloured square per camera.
  for (const [label, color] of [["A", COLOR_A], ["B", COLOR_B]]) {
    const square = document.createElement("span");
    square.textContent = " ■ ";
    square.style.color = `#${color.toString(16).padStart(6, "0")}`;
    $("viewer-info").append(square, label);
  }

  resize();
  frame(box);
  render();
  document.body.dataset.loaded = "1";
}

main().catch((err) => fail(err.message || String(err)));
