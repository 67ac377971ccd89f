// The status page: the daemon's status and events (Server-Sent Events, docs/web.md), the
// spool's entries, and the capture button. No framework: a few functions over the DOM.

const $ = (id) => document.getElementById(id);
const TOKEN_KEY = "monomesh-token";
const STATUS_PERIOD_MS = 2000;
// The entry's files offered for download, in this order (obj.zip is made from mesh.obj).
const DOWNLOADS = ["mesh.glb", "obj.zip", "mesh.ply", "points.ply",
                   "cameras.txt", "images.txt", "points3D.txt"];

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
  $("capture-number").textContent = capture ? `(capture ${capture})` : "";
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

function showStatus(status) {
  showState(status.state, status.captures);
  if (status.state === "tracking" && status.gate) showGate(status.gate);
  if (status.camera) showCamera(status.camera);
  showLastResult(status.last_result);
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

function figures(e) {
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
  const viewer = `/viewer.html?entry=${encodeURIComponent(e.name)}`;
  const when = e.time_unix_s ? new Date(e.time_unix_s * 1000).toLocaleString() : "";

  const result = e.report_error ? el("p", { class: "error" }, `report: ${e.report_error}`)
    : e.success ? el("p", { class: "ok" }, "mesh made")
    : el("p", { class: "error" }, `failed: ${e.failure_reason || "unknown reason"}`);

  const links = el("p", { class: "links" });
  if (has("mesh.glb")) links.append(el("a", { href: viewer, class: "view" }, "view in 3-D"));
  for (const file of DOWNLOADS.filter(has)) {
    links.append(el("a", { href: `${entryUrl(e.name, file)}?download=1`, download: "" }, file));
  }

  const preview = has("preview.png")
    ? el("a", { href: viewer }, el("img", { class: "preview", src: entryUrl(e.name, "preview.png"),
                                            alt: `preview of ${e.name}`, loading: "lazy" }))
    : el("div", { class: "preview none" }, "no preview");

  return el("li", { class: `entry ${e.success ? "success" : "failure"}`, "data-name": e.name },
            preview,
            el("div", { class: "about" },
               el("h3", {}, e.name, " ", el("time", {}, when)),
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
  on("capture_abandoned", (f) => showLastResult({ ...f, ok: false }));
  on("camera_error", (c) => {
    $("camera-errors").textContent = c.errors;
    $("camera-last-error").textContent = `last error: ${c.error}`;
  });
  events.onerror = () => showBanner("event stream lost; reconnecting…");
}

// --- capture ------------------------------------------------------------------------------

async function capture(event) {
  event.preventDefault();
  const input = $("token");
  const out = $("capture-result");
  // A typed token replaces the stored one; the field is emptied once it is kept.
  if (input.value.trim()) {
    sessionStorage.setItem(TOKEN_KEY, input.value.trim());
    input.value = "";
  }
  const token = sessionStorage.getItem(TOKEN_KEY);
  input.placeholder = token ? "token kept for this session" : "token";
  out.textContent = "…";
  out.dataset.outcome = "pending";
  try {
    const answer = await fetch("/api/trigger", {
      method: "POST",
      headers: token ? { Authorization: `Bearer ${token}` } : {},
    });
    const body = await answer.json().catch(() => ({}));
    if (answer.status === 401) {
      sessionStorage.removeItem(TOKEN_KEY);  // asked again next time
      input.placeholder = "token";
      out.textContent = "401: token refused";
      out.dataset.outcome = "refused";
    } else if (answer.ok && body.ok) {
      out.textContent = `capture ${body.capture} started`;
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

// --- start --------------------------------------------------------------------------------

if (sessionStorage.getItem(TOKEN_KEY)) $("token").placeholder = "token kept for this session";
$("capture-form").addEventListener("submit", capture);
pollStatus();
refreshEntries();
listen();
setInterval(pollStatus, STATUS_PERIOD_MS);
