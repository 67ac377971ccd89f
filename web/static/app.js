// The status page: the daemon's status and events (Server-Sent Events, docs/web.md), the
// spool's entries, and the capture and walk buttons. No framework: a few functions over the DOM.

const $ = (id) => document.getElementById(id);
const TOKEN_KEY = "monomesh-token";
const STATUS_PERIOD_MS = 2000;
// The entry's files offered for download, in this order, by the entry's kind (a pair's obj.zip
// is made from mesh.obj; a walk's trajectory.txt is TUM format, camera-to-world).
const DOWNLOADS = {
  pair: ["mesh.glb", "obj.zip", "mesh.ply", "points.ply", "cameras.txt", "images.txt",
         "points3D.txt"],
  walk: ["map.glb", "map.ply", "points.ply", "trajectory.txt", "cameras.txt", "images.txt",
         "points3D.txt"],
};

// Creates an element: attributes from `attrs`, then children (strings become text).
function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) node.setAttribute(key, value);
  node.append(...children.filter((c) => c !== null && c !== undefined));
  return node;
}

// JSON from the API; an error answer throws "STATUS: error".
async function getJson(url) {
  const answer = await fetch(url, { cache: "no-store" });
  const body = await answer.json().catch(() => ({}));
  if (!answer.ok) throw new Error(`${answer.status}: ${body.error || answer.statusText}`);
  return body;
}

const entryUrl = (name, file = "") =>
  `/api/entries/${encodeURIComponent(name)}${file ? "/" + file : ""}`;
const baseName = (path) => String(path || "").split("/").filter(Boolean).pop() || "";

// --- the banner ---------------------------------------------------------------------------

function showBanner(text) {
  const banner = $("daemon-banner");
  banner.textContent = text;
  banner.hidden = !text;
}

// --- status -------------------------------------------------------------------------------

let gateTarget = null;   // target_deg of the last gate event (the status does not carry it)
let lastFrames = null;   // {frames, t}: the previous poll, for the frame rate

function showState(state, capture) {
  const node = $("state");
  node.textContent = state;
  node.dataset.state = state;
  $("capture-number").textContent = capture && state !== "walking" ? `(capture ${capture})` : "";
  if (state === "idle") showGate(null);
}

// The gate's progress toward keyframe B: parallax over its target; null clears it.
function showGate(gate) {
  const bar = $("gate-progress");
  const text = $("gate-text");
  if (!gate) {
    bar.value = 0;
    text.textContent = "";
    return;
  }
  if (gate.target_deg > 0) gateTarget = gate.target_deg;
  const parallax = Number(gate.parallax_deg) || 0;
  if (gateTarget) bar.value = Math.min(parallax / gateTarget, 1);
  text.textContent = `${parallax.toFixed(2)}°` +
    (gateTarget ? ` of ${gateTarget.toFixed(2)}°` : "") +
    (gate.tracks !== undefined ? `, ${gate.tracks} tracks` : "") +
    (gate.reason ? ` (${gate.reason})` : "");
}

function showCamera(camera) {
  $("camera-dropped").textContent = camera.dropped ?? "–";
  $("camera-errors").textContent = camera.errors ?? "–";
  $("camera-last-error").textContent = camera.last_error ? `last error: ${camera.last_error}` : "";
  // Frame rate: the daemon's own measure (camera.frame_rate_hz); a daemon without it, from
  // the frame counter's growth between two polls.
  const now = performance.now();
  if (typeof camera.frame_rate_hz === "number") {
    $("camera-fps").textContent = camera.frame_rate_hz.toFixed(1);
  } else if (lastFrames && camera.frames >= lastFrames.frames && now > lastFrames.t) {
    const fps = (camera.frames - lastFrames.frames) / ((now - lastFrames.t) / 1000);
    $("camera-fps").textContent = fps.toFixed(1);
  }
  lastFrames = { frames: camera.frames, t: now };
}

// The last capture's outcome: {capture, ok, entry, error, seconds, b_tries} (or null).
function showLastResult(result) {
  const node = $("last-result");
  if (!result) {
    node.textContent = "none yet";
    delete node.dataset.ok;
    return;
  }
  node.dataset.ok = result.ok ? "1" : "0";
  const tries = result.b_tries ? `, ${result.b_tries} B tried` : "";
  const seconds = result.seconds ? `, ${Number(result.seconds).toFixed(1)} s` : "";
  node.textContent = result.ok
    ? `capture ${result.capture}: entry ${baseName(result.entry)}${seconds}${tries}`
    : `capture ${result.capture} failed: ${result.error}${tries}`;
}

// The walk (status.walk, docs/control.md): while walking, its keyframes and the parallax
// toward the next one; then its last result.
function showWalk(walk) {
  const state = $("walk-state");
  const bar = $("walk-progress");
  state.dataset.walking = walk.walking ? "1" : "0";
  bar.hidden = !walk.walking;
  if (walk.walking) {
    state.textContent = walk.finishing ? `walk ${walk.walk}: making its entry`
                                       : `walk ${walk.walk}: walking`;
    const target = Number(walk.target_deg) || 0;
    const parallax = Number(walk.parallax_deg) || 0;
    bar.value = target > 0 ? Math.min(parallax / target, 1) : 0;
    const segments = walk.segments ?? 1;
    $("walk-text").textContent = `${walk.keyframes} keyframes, ${walk.registered} registered, ` +
      `${segments} segment${segments === 1 ? "" : "s"}, ` +
      `${walk.relocalizations ?? 0} relocalised, ${walk.loop_closures ?? 0} loops closed, ` +
      `${walk.frames} frames (${walk.tracking ? "tracking" : "not tracking"}), ` +
      `${Number(walk.seconds).toFixed(0)} s` +
      (walk.finishing ? "" : `; next keyframe at ${parallax.toFixed(2)}° of ${target.toFixed(2)}°`);
  } else {
    state.textContent = "not walking";
    $("walk-text").textContent = "";
  }
  if ("last_result" in walk) showWalkResult(walk.last_result);  // not in a walk_frame event
}

// The last walk's outcome: {walk, ok, entry, error, reason, keyframes, registered, segments}.
function showWalkResult(result) {
  const node = $("walk-last-result");
  if (!result) {
    node.textContent = "";
    delete node.dataset.ok;
    return;
  }
  node.dataset.ok = result.ok ? "1" : "0";
  const counts = `${result.keyframes} keyframes, ${result.registered} registered, ` +
    `${result.segments} segments`;
  node.textContent = result.ok
    ? `last walk ${result.walk} (${result.reason}): entry ${baseName(result.entry)}, ${counts}`
    : `last walk ${result.walk} failed: ${result.error}`;
}

function showStatus(status) {
  showState(status.state, status.captures);
  if (status.state === "tracking" && status.gate) showGate(status.gate);
  if (status.camera) showCamera(status.camera);
  showLastResult(status.last_result);
  if (status.walk) showWalk(status.walk);
}

async function pollStatus() {
  try {
    showStatus(await getJson("/api/status"));
    showBanner("");
  } catch (err) {
    showBanner(err.message.startsWith("503") ? "daemon unreachable"
                                             : `web service unreachable (${err.message})`);
  }
}

// --- entries ------------------------------------------------------------------------------

function walkFigures(e) {
  const parts = [`${e.keyframes} keyframes`, `${e.registered} registered`,
                 `${e.segments} segment${e.segments === 1 ? "" : "s"}`];
  if (e.stop_reason) parts.push(`stopped: ${e.stop_reason}`);
  if (e.walk_seconds) parts.push(`${Number(e.walk_seconds).toFixed(0)} s`);
  for (const key of ["vertices", "triangles", "points"]) {
    if (e[key] !== undefined) parts.push(`${e[key]} ${key}`);
  }
  if (e.units) parts.push(`units: ${e.units}`);
  return parts.join(" · ");
}

function figures(e) {
  if (e.kind === "walk") return walkFigures(e);
  const parts = [];
  if (e.pair) parts.push(`pair ${e.pair}`);
  if (e.mesh_mode) parts.push(`${e.mesh_mode} mesh`);
  for (const key of ["vertices", "triangles", "points", "inliers"]) {
    if (e[key] !== undefined) parts.push(`${e[key]} ${key}`);
  }
  if (e.median_triangulation_angle_deg !== undefined) {
    parts.push(`${Number(e.median_triangulation_angle_deg).toFixed(2)}° median angle`);
  }
  if (e.reprojection_rms_px !== undefined) {
    parts.push(`${Number(e.reprojection_rms_px).toFixed(2)} px rms`);
  }
  if (e.units) parts.push(`units: ${e.units}`);
  return parts.join(" · ");
}

function entryItem(e) {
  const files = e.files || [];
  const has = (file) => files.includes(file) || (file === "obj.zip" && files.includes("mesh.obj"));
  const walk = e.kind === "walk";
  const viewer = `/viewer.html?entry=${encodeURIComponent(e.name)}`;
  const when = e.time_unix_s ? new Date(e.time_unix_s * 1000).toLocaleString() : "";

  const result = e.report_error ? el("p", { class: "error" }, `report: ${e.report_error}`)
    : e.success ? el("p", { class: "ok" }, walk ? "map made" : "mesh made")
    : el("p", { class: "error" }, `failed: ${e.failure_reason || "unknown reason"}`);

  const links = el("p", { class: "links" });
  if (has(walk ? "map.glb" : "mesh.glb")) {
    links.append(el("a", { href: viewer, class: "view" }, "view in 3-D"));
  }
  for (const file of DOWNLOADS[walk ? "walk" : "pair"].filter(has)) {
    links.append(el("a", { href: `${entryUrl(e.name, file)}?download=1`, download: "" }, file));
  }

  const preview = has("preview.png")
    ? el("a", { href: viewer }, el("img", { class: "preview", src: entryUrl(e.name, "preview.png"),
                                            alt: `preview of ${e.name}`, loading: "lazy" }))
    : el("div", { class: "preview none" }, "no preview");

  return el("li", { class: `entry ${e.success ? "success" : "failure"}`, "data-name": e.name },
            preview,
            el("div", { class: "about" },
               el("h3", {}, e.name, walk ? el("span", { class: "kind" }, "walk") : null, " ",
                  el("time", {}, when)),
               result,
               el("p", { class: "figures" }, figures(e)),
               links));
}

let entriesAsked = 0;  // only the newest answer is shown when fetches overlap

async function refreshEntries() {
  const ask = ++entriesAsked;
  try {
    const { entries } = await getJson("/api/entries");
    if (ask !== entriesAsked) return;
    // Items are kept by name while their summary is unchanged: no image reloads, no flicker.
    const kept = new Map([...$("entries").children].map((li) => [li.dataset.name, li]));
    $("entries").replaceChildren(...entries.map((e) => {
      const summary = JSON.stringify(e);
      const old = kept.get(e.name);
      if (old && old.summary === summary) return old;
      return Object.assign(entryItem(e), { summary });
    }));
    $("entries-error").hidden = true;
  } catch (err) {
    $("entries-error").textContent = `entries: ${err.message}`;
    $("entries-error").hidden = false;
  }
}

// --- the event stream ---------------------------------------------------------------------

function listen() {
  const events = new EventSource("/api/events");
  const on = (name, handle) => events.addEventListener(name, (message) => {
    let data = {};
    try { data = JSON.parse(message.data); } catch { /* an empty data line */ }
    handle(data);
  });
  // First on every (re)connection: the whole status; entries may have come meanwhile.
  on("status", (status) => { showBanner(""); showStatus(status); refreshEntries(); });
  on("daemon", (d) => { if (d.connected === false) showBanner("daemon unreachable"); });
  on("state", (s) => showState(s.state, s.capture));
  on("keyframe_a", () => { gateTarget = null; showGate({ parallax_deg: 0 }); });
  on("gate", showGate);
  on("keyframe_b", (b) => {  // the gate is done: at its target, or the tracks broke
    $("gate-progress").value = 1;
    $("gate-text").textContent = `keyframe B taken (frame ${b.frame}, ` +
      `${Number(b.parallax_deg).toFixed(2)}°${b.after_lost_track ? ", tracks lost" : ""})`;
  });
  on("keyframe_b_refused", (r) => { $("gate-text").textContent = `B refused: ${r.reason}`; });
  on("entry", (e) => {
    showLastResult({ ...e, ok: true });
    refreshEntries();
  });
  on("capture_failed", (f) => showLastResult({ ...f, ok: false }));
  // A walk's events carry only what changed: the whole walk comes from the status.
  for (const name of ["walk_started", "walk_keyframe", "walk_stopping", "walk_failed"]) {
    on(name, pollStatus);
  }
  on("walk_frame", showWalk);  // the walk's progress between keyframes, 5 a second at most
  on("walk_entry", () => { pollStatus(); refreshEntries(); });
  on("walk_refused", (r) => {
    $("walk-last-result").textContent = `walk refused: ${r.error}`;
    $("walk-last-result").dataset.ok = "0";
  });
  on("capture_abandoned", (f) => showLastResult({ ...f, ok: false }));
  on("camera_error", (c) => {
    $("camera-errors").textContent = c.errors;
    $("camera-last-error").textContent = `last error: ${c.error}`;
  });
  events.onerror = () => showBanner("event stream lost; reconnecting…");
}

// --- the buttons: capture, walk start and stop --------------------------------------------

// Reads a typed token (it replaces the stored one; the field is emptied once it is kept) and
// returns the token to send.
function takeToken() {
  const input = $("token");
  if (input.value.trim()) {
    sessionStorage.setItem(TOKEN_KEY, input.value.trim());
    input.value = "";
  }
  const token = sessionStorage.getItem(TOKEN_KEY);
  input.placeholder = token ? "token kept for this session" : "token";
  return token;
}

// POSTs `url` with the token and shows the outcome in #capture-result; `describe` turns the
// daemon's accepting answer into words.
async function press(url, describe) {
  const out = $("capture-result");
  const token = takeToken();
  out.textContent = "…";
  out.dataset.outcome = "pending";
  try {
    const answer = await fetch(url, {
      method: "POST",
      headers: token ? { Authorization: `Bearer ${token}` } : {},
    });
    const body = await answer.json().catch(() => ({}));
    if (answer.status === 401) {
      sessionStorage.removeItem(TOKEN_KEY);  // asked again next time
      $("token").placeholder = "token";
      out.textContent = "401: token refused";
      out.dataset.outcome = "refused";
    } else if (answer.ok && body.ok) {
      out.textContent = describe(body);
      out.dataset.outcome = "ok";
    } else if (answer.ok) {
      out.textContent = `refused: ${body.error || "no reason given"}`;  // e.g. busy: tracking
      out.dataset.outcome = "error";
    } else {
      out.textContent = `${answer.status}: ${body.error || answer.statusText}`;
      out.dataset.outcome = "error";
    }
  } catch (err) {
    out.textContent = `no answer: ${err.message}`;
    out.dataset.outcome = "error";
  }
}

function capture(event) {
  event.preventDefault();
  return press("/api/trigger", (body) => `capture ${body.capture} started`);
}

// --- start --------------------------------------------------------------------------------

if (sessionStorage.getItem(TOKEN_KEY)) $("token").placeholder = "token kept for this session";
$("capture-form").addEventListener("submit", capture);
$("walk-start").addEventListener("click",
  () => press("/api/walk/start", (body) => `walk ${body.walk} started`));
$("walk-stop").addEventListener("click",
  () => press("/api/walk/stop", (body) => `walk ${body.walk} stopping (${body.keyframes} keyframes)`));
pollStatus();
refreshEntries();
listen();
setInterval(pollStatus, STATUS_PERIOD_MS);
