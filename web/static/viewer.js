// The 3-D view of one entry with OrbitControls, framed on the mesh: a pair's mesh.glb with its
// two keyframe cameras as wireframe frusta (camera B from report.json's relative_pose), or a
// walk's map.glb with every registered keyframe of the map's segment as a frustum (from
// report.json's keyframes[].cam_from_segment) and the path through them.
//
// Frames: report.json is in camera A's (a walk: the segment's first keyframe's) OpenCV frame
// (x right, y down, z forward); the GLB stores (x, -y, -z) of it, so the mesh is y up and that
// camera sits at the origin looking down -z, which is also three.js's camera convention.
import * as THREE from "three";
import { GLTFLoader } from "/three/examples/jsm/loaders/GLTFLoader.js";
import { OrbitControls } from "/three/examples/jsm/controls/OrbitControls.js";

const BACKGROUND = 0x1b1f24;
const COLOR_A = 0x4fc3f7;
const COLOR_B = 0xffb74d;
const COLOR_PATH = 0xe0e0e0;

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

// A camera's pose in the GLB frame from cam_from_world (X_cam = R X_world + t, world: camera
// A's or the segment's OpenCV frame): its centre is C = -R^T t; with F = diag(1, -1, -1)
// (OpenCV <-> GLB axes, F = F^-1) a point q in the camera's GLB-style frame is at
// F R^T F q + F C.
function cameraMatrix(R, t) {
  const C = [0, 1, 2].map((i) => -(R[0][i] * t[0] + R[1][i] * t[1] + R[2][i] * t[2]));
  const f = [1, -1, -1];
  const m = (i, j) => f[i] * R[j][i] * f[j];  // (F R^T F)_ij
  return new THREE.Matrix4().set(
    m(0, 0), m(0, 1), m(0, 2), f[0] * C[0],
    m(1, 0), m(1, 1), m(1, 2), f[1] * C[1],
    m(2, 0), m(2, 1), m(2, 2), f[2] * C[2],
    0, 0, 0, 1);
}

// The rotation matrix of a unit quaternion (w, x, y, z).
function rotationOf([w, x, y, z]) {
  return [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
          [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
          [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]];
}

// The intrinsics' half extents over the focal length, for the frusta.
function halfExtents(report) {
  const [width, height] = (report.camera && report.camera.image_size) || [640, 480];
  const [fx, fy] = (report.camera && report.camera.fc) || [width, width];
  return [width / 2 / fx, height / 2 / fy];
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

// The view camera: on camera A's (the walk's first keyframe's) side of the mesh, above it by
// `lift` (the rise over the horizontal), just far enough back that every corner of the box is
// in view.
function frame(box, lift) {
  const centre = box.getCenter(new THREE.Vector3());
  const toA = centre.clone().negate();
  const back = (toA.lengthSq() > 0 ? toA.normalize() : new THREE.Vector3(0, 0, 1));
  back.add(new THREE.Vector3(0, lift, 0)).normalize();
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

// A pair: cameras A and B, and the baseline. Returns {count: 2, centres: []}.
function drawPairCameras(report, box) {
  const [halfW, halfH] = halfExtents(report);
  const pose = report.relative_pose;
  const diagonal = box.getSize(new THREE.Vector3()).length();
  let depth = 0.04 * diagonal;
  let info = "";
  if (pose && pose.rotation && pose.translation) {
    const b = cameraMatrix(pose.rotation, pose.translation);
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
  return { count: 2, centres: [] };
}

// A walk: the registered keyframes of the map's segment, first (COLOR_A) to last (COLOR_B),
// and the path through their centres. Returns {count, centres} of the frusta drawn.
function drawWalkCameras(report, box) {
  const [halfW, halfH] = halfExtents(report);
  const poses = (report.keyframes || [])
    .filter((k) => k.registered && k.segment === report.map_segment && k.cam_from_segment)
    .map((k) => cameraMatrix(rotationOf(k.cam_from_segment.quaternion_wxyz),
                             k.cam_from_segment.translation));
  const centres = poses.map((m) => new THREE.Vector3().setFromMatrixPosition(m));
  // Deep enough to see, shallower than the median step so that neighbours do not overlap.
  const steps = centres.slice(1).map((c, i) => c.distanceTo(centres[i])).sort((a, b) => a - b);
  const diagonal = box.getSize(new THREE.Vector3()).length();
  const depth = steps.length ? Math.min(0.04 * diagonal, 0.8 * steps[steps.length >> 1]) || 0.04 * diagonal
                             : 0.04 * diagonal;
  const first = new THREE.Color(COLOR_A), last = new THREE.Color(COLOR_B);
  poses.forEach((m, i) => {
    const color = first.clone().lerp(last, poses.length > 1 ? i / (poses.length - 1) : 0);
    const f = frustum(depth, halfW, halfH, color);
    f.matrixAutoUpdate = false;
    f.matrix.copy(m);
    f.name = "keyframe";
    scene.add(f);
  });
  if (centres.length > 1) {
    const path = new THREE.BufferGeometry().setFromPoints(centres);
    scene.add(new THREE.Line(path, new THREE.LineBasicMaterial({ color: COLOR_PATH })));
  }

  const counts = report.counts || {};
  const units = (report.scale && report.scale.units) || "?";
  $("viewer-info").textContent =
    `walk: ${counts.keyframes ?? "?"} keyframes, ${poses.length} in the map's segment · ` +
    `${counts.mesh_vertices ?? "?"} vertices · ${counts.mesh_triangles ?? "?"} triangles · ` +
    `units: ${units} · drag to orbit, wheel to zoom`;
  for (const [label, color] of [["first", COLOR_A], ["last keyframe", COLOR_B]]) {
    const square = document.createElement("span");
    square.textContent = " ■ ";
    square.style.color = `#${color.toString(16).padStart(6, "0")}`;
    $("viewer-info").append(square, label);
  }
  return { count: poses.length, centres };
}

async function main() {
  if (!name) throw new Error("no entry given (viewer.html?entry=NAME)");
  $("viewer-title").textContent = name;
  // The report says the entry's kind, and with it which mesh to load.
  const report = await loadReport().catch((err) => ({ error: err.message }));
  const walk = report.kind === "walk";
  const gltf = await loadGlb(entryUrl(walk ? "map.glb" : "mesh.glb"));

  // The texture is the photograph (unlit); both sides, as the mesh is seen from one side only.
  gltf.scene.traverse((node) => { if (node.isMesh) node.material.side = THREE.DoubleSide; });
  scene.add(gltf.scene);
  const box = robustBox(gltf.scene);
  if (box.isEmpty()) throw new Error(`${walk ? "map" : "mesh"}.glb holds no geometry`);

  const cameras = walk ? drawWalkCameras(report, box) : drawPairCameras(report, box);
  // A walk's path is framed with its map: the keyframes may stand outside the mesh's box.
  if (walk) for (const centre of cameras.centres) box.expandByPoint(centre);

  // A pair is seen a little from above, as camera A saw it; a walk's map from higher, so that
  // the rooms along the path are not hidden behind the nearest walls.
  resize();
  frame(box, walk ? 1.0 : 0.3);
  render();
  document.body.dataset.kind = walk ? "walk" : "pair";
  document.body.dataset.cameras = String(cameras.count);
  document.body.dataset.loaded = "1";
}

main().catch((err) => fail(err.message || String(err)));
