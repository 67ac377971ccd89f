#!/usr/bin/python3
"""Real-browser test of monomesh-web's pages (docs/web.md) with headless Chromium.

Starts monomeshd on the bundled dataset (replay camera at 1x, looping, as scripts/demo.sh
does) and monomesh-web beside it, presses capture once over the control socket so an entry
exists, then drives the pages with Selenium:

  entries_listed    the index page lists that entry, with its preview and download links
  downloads         the entry's download links answer, as attachments
  status_panel      the status panel shows the daemon's state and the camera's frame rate
  viewer_loaded     viewer.html?entry=NAME loads the mesh; the canvas shows it (pixels measured)
  viewer_orbit      a drag on the canvas orbits the view (the picture changes, measured)
  viewer_error      the viewer of an entry that does not exist says so (data-error)
  capture_refused   Capture without a token, and with a wrong one: 401 shown, no capture started
  capture_live      Capture with the token: the state, the gate's progress and the new entry
                    follow live, without a reload
  walk_live         Start walk with the token: the walk's keyframes count up live; Stop walk:
                    the walk's entry appears first in the list, marked as a walk, without a
                    reload
  walk_viewer       viewer.html?entry=WALK loads the map; one frustum per registered keyframe
                    of the map's segment; the canvas shows the map (pixels measured)
  post_401          a plain POST /api/trigger or /api/walk/start|stop without Authorization
                    (or a wrong token): 401
  daemon_banner     the daemon stopped: the page says it is unreachable

One `CHECK ok|FAILED NAME` line per check; exit 1 on any failure (with both processes' logs
and the browser's console). Needs chromium, chromium-driver, python3-selenium and python3-pil
(Debian's packages, so run it with /usr/bin/python3); exit 77 (skipped) when they are not
installed.

  tests/web/browser_test.py --web-bin build/default/firmware-app/monomesh-web \
      --daemon-bin build/default/firmware-app/monomeshd \
      --ctl-bin build/default/firmware-app/monomesh --data data/tum_office --out /tmp/webtest
"""
import argparse
import base64
import io
import json
import os
import random
import re
import shutil
import subprocess
import sys
import time

SKIP = 77  # ctest's SKIP_RETURN_CODE: the browser or its Python bindings are not installed

try:
    from PIL import Image, ImageChops
    from selenium import webdriver
    from selenium.common.exceptions import TimeoutException
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait
except ImportError as missing:
    print(f"SKIP: {missing} (scripts/install-deps.sh browser)")
    sys.exit(SKIP)

from webtest_support import (Failed, Processes, free_port, get_json, http, run_check, wait_for,
                             write_config)

CAPTURE_WAIT_S = 120

# viewer.js's clear colour (BACKGROUND) and how far a channel may stray from it and still
# count as background (antialiasing, sRGB rounding).
BACKGROUND_RGB = (0x1B, 0x1F, 0x24)
CHANNEL_TOLERANCE = 12
# Share of canvas pixels that must show something other than the background: the mesh covers
# 0.12-0.14 of the 1280x757 canvas framed on it (measured with SwiftShader on four entries of
# the bundled dataset); at most MAX_MESH_FRACTION, so that a canvas of one wrong colour fails.
MIN_MESH_FRACTION = 0.05
MAX_MESH_FRACTION = 0.6
# A walk's map is framed with its keyframes' path and seen from higher up: 0.070 of the canvas
# measured on a 4-keyframe walk of the bundled dataset; the frusta and path alone are < 0.01.
MIN_WALK_MAP_FRACTION = 0.035
# Share of canvas pixels that must change with the orbit drag (120 px; measured 0.18-0.20).
MIN_ORBIT_CHANGE = 0.05

ENTRY_FILES = ["mesh.glb", "obj.zip", "mesh.ply", "points.ply",
               "cameras.txt", "images.txt", "points3D.txt"]
WALK_FILES = ["map.glb", "map.ply", "points.ply", "trajectory.txt",
              "cameras.txt", "images.txt", "points3D.txt"]
# Keyframes the walk takes before it is stopped: the replay's frames are 1 s apart, each one
# past the walk's parallax gate, so this is a few seconds of walking.
WALK_KEYFRAMES = 4


def canvas_image(driver):
    """The viewer's WebGL drawing buffer (preserveDrawingBuffer) as an RGB image."""
    url = driver.execute_script(
        "return document.getElementById('viewer-canvas').toDataURL('image/png');")
    return Image.open(io.BytesIO(base64.b64decode(url.split(",", 1)[1]))).convert("RGB")


def changed_fraction(image, other):
    """Share of pixels where some channel differs by more than CHANNEL_TOLERANCE."""
    if image.size != other.size:
        return 1.0
    # The largest of the three channel differences, per pixel.
    r, g, b = ImageChops.difference(image, other).split()
    diff = ImageChops.lighter(ImageChops.lighter(r, g), b)
    histogram = diff.histogram()
    changed = sum(histogram[CHANNEL_TOLERANCE + 1:])
    return changed / (image.size[0] * image.size[1])


def start_browser():
    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium")
    for flag in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                 "--window-size=1280,900", "--use-angle=swiftshader",
                 "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(executable_path=shutil.which("chromedriver")),
                            options=options)


class Test:
    def __init__(self, args):
        self.args = args
        self.out = os.path.abspath(args.out)
        os.makedirs(self.out, exist_ok=True)
        self.processes = Processes(self.out)
        self.driver = None
        self.failures = []
        self.token = "".join(random.Random(1).choice("0123456789abcdef") for _ in range(32))
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.socket = None
        self.entry = None
        self.walk_entry = None

    def check(self, name, function):
        run_check(self.failures, name, function, expected=(Failed, TimeoutException))

    def screenshot(self, element, file_name):
        path = os.path.join(self.out, file_name)
        if element is None:
            self.driver.save_screenshot(path)
        else:
            element.screenshot(path)
        if self.args.screenshots_to:
            os.makedirs(self.args.screenshots_to, exist_ok=True)
            shutil.copy(path, os.path.join(self.args.screenshots_to, file_name))

    def captures(self):
        return get_json(self.base + "/api/status")["captures"]

    def entry_names(self):
        return [e["name"] for e in get_json(self.base + "/api/entries")["entries"]]

    # --- setup --------------------------------------------------------------------------

    def setup(self):
        config, self.socket = write_config(self.args, self.out, self.port, self.token)
        self.processes.start("monomeshd", [self.args.daemon_bin, "--config", config])
        ctl = [self.args.ctl_bin, "ctl"]
        ping = ctl + ["ping", "--socket", self.socket]
        wait_for("monomeshd's control socket", lambda: self.processes.alive("monomeshd") and
                 subprocess.run(ping, capture_output=True).returncode == 0, 30)
        self.processes.start("monomesh-web", [self.args.web_bin, "--config", config])
        wait_for("GET /api/status to answer 200", lambda: self.processes.alive("monomesh-web")
                 and http(self.base + "/api/status")[0] == 200, 30)
        # One entry to look at, made over the control socket (not through the page).
        result = subprocess.run(ctl + ["trigger", "--wait", str(CAPTURE_WAIT_S),
                                       "--socket", self.socket], capture_output=True, text=True)
        found = re.search(r'"entry":\s*"([^"]+)"', result.stdout)
        if result.returncode != 0 or not found:
            raise Failed(f"monomesh ctl trigger: exit {result.returncode}: "
                         f"{result.stdout.strip()} {result.stderr.strip()}")
        self.entry = os.path.basename(found.group(1).rstrip("/"))
        self.driver = start_browser()
        self.driver.set_page_load_timeout(30)

    # --- the checks ---------------------------------------------------------------------

    def entry_item(self, name):
        found = self.driver.find_elements(By.CSS_SELECTOR, f'#entries .entry[data-name="{name}"]')
        return found[0] if found else None

    def entries_listed(self):
        self.driver.get(self.base + "/")
        item = WebDriverWait(self.driver, 20).until(lambda d: self.entry_item(self.entry))
        preview = item.find_element(By.CSS_SELECTOR, "img.preview")
        WebDriverWait(self.driver, 10).until(
            lambda d: d.execute_script("return arguments[0].complete && arguments[0].naturalWidth",
                                       preview))
        hrefs = [a.get_attribute("href") for a in item.find_elements(By.CSS_SELECTOR, ".links a")]
        for file in ENTRY_FILES:
            if not any(h.endswith(f"/{self.entry}/{file}?download=1") for h in hrefs):
                raise Failed(f"no download link for {file} in {hrefs}")
        if not any(h.endswith(f"/viewer.html?entry={self.entry}") for h in hrefs):
            raise Failed(f"no viewer link in {hrefs}")
        text = item.text
        for word in ("vertices", "triangles", "points", "units"):
            if word not in text:
                raise Failed(f"the entry's figures lack {word!r}: {text!r}")
        return f"{self.entry}: {item.find_element(By.CSS_SELECTOR, '.figures').text}"

    def downloads(self):
        sizes = []
        for file in ENTRY_FILES:
            status, headers, body = http(f"{self.base}/api/entries/{self.entry}/{file}?download=1")
            disposition = headers.get("Content-Disposition", "")
            if status != 200 or "attachment" not in disposition or not body:
                raise Failed(f"{file}: {status}, Content-Disposition {disposition!r}, "
                             f"{len(body)} bytes")
            if file == "obj.zip" and not body.startswith(b"PK"):
                raise Failed("obj.zip is not a zip")
            if file == "mesh.glb" and not body.startswith(b"glTF"):
                raise Failed("mesh.glb is not a GLB")
            sizes.append(f"{file} {len(body)}")
        return ", ".join(sizes)

    def status_panel(self):
        self.driver.get(self.base + "/")
        state = WebDriverWait(self.driver, 10).until(
            lambda d: d.find_element(By.ID, "state").text in ("idle", "tracking",
                                                              "reconstructing")
            and d.find_element(By.ID, "state").text)
        # The daemon's measured frame rate (camera.frame_rate_hz), shown from the first status.
        fps = WebDriverWait(self.driver, 15).until(
            lambda d: re.fullmatch(r"\d+(\.\d+)?", d.find_element(By.ID, "camera-fps").text)
            and float(d.find_element(By.ID, "camera-fps").text))
        if fps <= 0:
            raise Failed(f"camera frame rate {fps}")
        last = self.driver.find_element(By.ID, "last-result").text
        if self.entry not in last:
            raise Failed(f"#last-result {last!r} does not name {self.entry}")
        if not self.driver.find_element(By.ID, "daemon-banner").get_attribute("hidden"):
            raise Failed("the 'daemon unreachable' banner shows while the daemon runs")
        return f"state {state}, {fps} fps, last result {last!r}"

    def load_viewer(self, entry, file_prefix, min_fraction=MIN_MESH_FRACTION):
        """Opens the viewer on `entry`; returns its body element and the canvas's picture, whose
        share of non-background pixels must be within bounds."""
        self.driver.get(f"{self.base}/viewer.html?entry={entry}")
        body = self.driver.find_element(By.TAG_NAME, "body")
        WebDriverWait(self.driver, 60).until(
            lambda d: body.get_attribute("data-loaded") or body.get_attribute("data-error"))
        if body.get_attribute("data-error"):
            raise Failed(f"viewer: {body.get_attribute('data-error')}")
        time.sleep(0.5)
        view = canvas_image(self.driver)
        view.save(os.path.join(self.out, f"{file_prefix}-canvas.png"))
        self.screenshot(None, f"{file_prefix}.png")
        background = Image.new("RGB", view.size, BACKGROUND_RGB)
        fraction = changed_fraction(view, background)
        detail = f"{fraction:.3f} of {view.size[0]}x{view.size[1]} canvas pixels " \
                 f"are not background (need {min_fraction} to {MAX_MESH_FRACTION})"
        if not min_fraction <= fraction <= MAX_MESH_FRACTION:
            raise Failed(detail)
        return body, view, detail

    def viewer_loaded(self):
        _, self.view, detail = self.load_viewer(self.entry, "viewer")
        return detail

    def viewer_error(self):
        self.driver.get(f"{self.base}/viewer.html?entry=20000101T000000Z-000001")
        body = self.driver.find_element(By.TAG_NAME, "body")
        error = WebDriverWait(self.driver, 30).until(lambda d: body.get_attribute("data-error"))
        if body.get_attribute("data-loaded"):
            raise Failed("an entry that does not exist reached data-loaded")
        return f"data-error {error!r}"

    def viewer_orbit(self):
        canvas = self.driver.find_element(By.ID, "viewer-canvas")
        ActionChains(self.driver).move_to_element(canvas).click_and_hold() \
            .move_by_offset(40, 5).move_by_offset(40, 5).move_by_offset(40, 5) \
            .release().perform()
        time.sleep(0.5)
        orbited = canvas_image(self.driver)
        orbited.save(os.path.join(self.out, "viewer-canvas-orbited.png"))
        fraction = changed_fraction(self.view, orbited)
        detail = f"{fraction:.3f} of the canvas pixels changed (need {MIN_ORBIT_CHANGE})"
        if fraction < MIN_ORBIT_CHANGE:
            raise Failed(detail)
        return detail

    def press_capture(self, token):
        """Types `token` (None: leaves the field empty), clicks Capture, returns the answer."""
        field = self.driver.find_element(By.ID, "token")
        field.clear()
        if token is not None:
            field.send_keys(token)
        result = self.driver.find_element(By.ID, "capture-result")
        self.driver.execute_script("arguments[0].textContent = '';", result)
        self.driver.find_element(By.ID, "capture").click()
        return WebDriverWait(self.driver, 10).until(
            lambda d: result.text not in ("", "…") and result.text)

    def capture_refused(self):
        self.driver.get(self.base + "/")
        self.driver.execute_script("sessionStorage.clear();")
        WebDriverWait(self.driver, 10).until(lambda d: self.entry_item(self.entry))
        captures, names = self.captures(), self.entry_names()
        answers = [self.press_capture(None), self.press_capture("not-" + self.token)]
        for answer in answers:
            if "401" not in answer or "refused" not in answer:
                raise Failed(f"#capture-result says {answer!r}, not a refusal")
        time.sleep(2)
        if self.captures() != captures or self.entry_names() != names:
            raise Failed("a refused press started a capture or made an entry")
        return " / ".join(answers)

    def capture_live(self):
        # The page from capture_refused stays: a marker on window tells a reload. The capture
        # may take under a second (the replay's keyframes are 1 s apart, B is the next frame),
        # so the page records what #state and #gate-progress show as they change.
        self.driver.execute_script("""
            window.__noReload = 42;
            window.__seen = {states: [], progress: []};
            const state = document.getElementById('state');
            const bar = document.getElementById('gate-progress');
            new MutationObserver(() => __seen.states.push(state.textContent))
                .observe(state, {childList: true, characterData: true, subtree: true});
            new MutationObserver(() => __seen.progress.push(bar.value))
                .observe(bar, {attributes: true, attributeFilter: ['value']});""")
        before = set(self.entry_names())
        answer = self.press_capture(self.token)
        if "started" not in answer:
            raise Failed(f"#capture-result says {answer!r}")
        if self.driver.execute_script("return sessionStorage.getItem('monomesh-token');") != \
                self.token:
            raise Failed("the accepted token is not kept in sessionStorage")
        new_name = None
        try:
            new_name = WebDriverWait(self.driver, CAPTURE_WAIT_S + 30).until(lambda d: [
                e.get_attribute("data-name")
                for e in d.find_elements(By.CSS_SELECTOR, "#entries .entry")
                if e.get_attribute("data-name") not in before][:1])[0]
        except TimeoutException:
            raise Failed(f"no new entry in the list within {CAPTURE_WAIT_S + 30} s "
                         f"(the page saw {self.driver.execute_script('return __seen;')})")
        names = self.driver.execute_script(
            "return [...document.querySelectorAll('#entries .entry')].map((e) => e.dataset.name);")
        if names[0] != new_name:
            raise Failed(f"the new entry {new_name} is not first: {names}")
        if self.driver.execute_script("return window.__noReload;") != 42:
            raise Failed("the page was reloaded")
        WebDriverWait(self.driver, 10).until(
            lambda d: new_name in d.find_element(By.ID, "last-result").text)
        seen = self.driver.execute_script("return __seen;")
        states = [s for i, s in enumerate(seen["states"]) if i == 0 or seen["states"][i - 1] != s]
        if "tracking" not in states or "reconstructing" not in states:
            raise Failed(f"#state did not follow the capture: {states}")
        if max(seen["progress"] or [0]) < 1:
            raise Failed(f"#gate-progress never reached keyframe B: {seen['progress']}")
        WebDriverWait(self.driver, 10).until(
            lambda d: d.execute_script(
                "return [...document.querySelectorAll('#entries img.preview')]"
                ".every((i) => i.complete && i.naturalWidth > 0);"))
        self.screenshot(self.driver.find_element(By.ID, "status-panel"), "status.png")
        self.screenshot(self.driver.find_element(By.ID, "entries"), "entries.png")
        return f"{new_name} listed first without a reload; #state went {' -> '.join(states)}, " \
               f"#gate-progress {seen['progress']}"

    def walk_status(self):
        return get_json(self.base + "/api/status")["walk"]

    def walk_live(self):
        # The page from capture_live stays (its token kept): the walk is started and stopped
        # with the page's buttons and followed on the page, without a reload.
        self.driver.execute_script("window.__noReload = 43;")
        before = set(self.entry_names())
        walks = self.walk_status()["walk"]
        result = self.driver.find_element(By.ID, "capture-result")
        self.driver.execute_script("arguments[0].textContent = '';", result)
        self.driver.find_element(By.ID, "walk-start").click()
        answer = WebDriverWait(self.driver, 10).until(
            lambda d: result.text not in ("", "…") and result.text)
        if "walk" not in answer or "started" not in answer:
            raise Failed(f"#capture-result says {answer!r} after Start walk")
        walk_text = self.driver.find_element(By.ID, "walk-text")
        try:
            WebDriverWait(self.driver, 60).until(lambda d: (
                re.match(r"(\d+) keyframes", walk_text.text) and
                int(re.match(r"(\d+) keyframes", walk_text.text).group(1)) >= WALK_KEYFRAMES))
        except TimeoutException:
            raise Failed(f"#walk-text did not reach {WALK_KEYFRAMES} keyframes: "
                         f"{walk_text.text!r}; status {self.walk_status()}")
        walking = self.driver.find_element(By.ID, "walk-state").text
        self.screenshot(self.driver.find_element(By.ID, "status-panel"), "status-walk.png")
        self.driver.execute_script("arguments[0].textContent = '';", result)
        self.driver.find_element(By.ID, "walk-stop").click()
        answer = WebDriverWait(self.driver, 10).until(
            lambda d: result.text not in ("", "…") and result.text)
        if "stopping" not in answer:
            raise Failed(f"#capture-result says {answer!r} after Stop walk")
        try:
            self.walk_entry = WebDriverWait(self.driver, CAPTURE_WAIT_S).until(lambda d: [
                e.get_attribute("data-name")
                for e in d.find_elements(By.CSS_SELECTOR, "#entries .entry")
                if e.get_attribute("data-name") not in before][:1])[0]
        except TimeoutException:
            raise Failed(f"no walk entry in the list within {CAPTURE_WAIT_S} s "
                         f"(status {self.walk_status()})")
        if self.driver.execute_script("return window.__noReload;") != 43:
            raise Failed("the page was reloaded")
        item = self.entry_item(self.walk_entry)
        text = item.text
        for word in ("walk", "keyframes", "registered", "map made"):
            if word not in text:
                raise Failed(f"the walk entry's item lacks {word!r}: {text!r}")
        hrefs = [a.get_attribute("href") for a in item.find_elements(By.CSS_SELECTOR, ".links a")]
        for file in WALK_FILES:
            if not any(h.endswith(f"/{self.walk_entry}/{file}?download=1") for h in hrefs):
                raise Failed(f"no download link for {file} in {hrefs}")
        WebDriverWait(self.driver, 10).until(
            lambda d: self.walk_entry in d.find_element(By.ID, "walk-last-result").text)
        status = self.walk_status()
        if status["walking"] or status["walk"] != walks + 1:
            raise Failed(f"after the stop the status says {status}")
        self.screenshot(self.driver.find_element(By.ID, "entries"), "entries-walk.png")
        return f"{walking!r}, {self.walk_entry} listed: " \
               f"{item.find_element(By.CSS_SELECTOR, '.figures').text}"

    def walk_viewer(self):
        if not self.walk_entry:
            raise Failed("no walk entry (walk_live failed)")
        report = get_json(f"{self.base}/api/entries/{self.walk_entry}")
        expected = sum(1 for k in report["keyframes"]
                       if k["registered"] and k["segment"] == report["map_segment"])
        body, _, detail = self.load_viewer(self.walk_entry, "viewer-walk", MIN_WALK_MAP_FRACTION)
        kind, cameras = body.get_attribute("data-kind"), body.get_attribute("data-cameras")
        if kind != "walk" or int(cameras or 0) != expected or expected < 2:
            raise Failed(f"data-kind {kind!r}, {cameras} frusta drawn, the report has "
                         f"{expected} registered keyframes in the map's segment")
        return f"{cameras} keyframe frusta; {detail}"

    def post_401(self):
        captures, walks = self.captures(), self.walk_status()["walk"]
        answers = []
        for path in ("/api/trigger", "/api/walk/start", "/api/walk/stop"):
            for headers in ({}, {"Authorization": "Bearer not-" + self.token},
                            {"Authorization": self.token}):
                status, response_headers, body = http(self.base + path, "POST", headers)
                if status != 401:
                    raise Failed(f"POST {path} with {headers or 'no Authorization'}: "
                                 f"{status} {body!r}")
                if "application/json" not in response_headers.get("Content-Type", "") or \
                        "error" not in json.loads(body):
                    raise Failed(f"the 401 answer is not an error object: {body!r}")
                answers.append(status)
        if self.captures() != captures or self.walk_status()["walk"] != walks:
            raise Failed("a refused POST started a capture or a walk")
        return f"/api/trigger, /api/walk/start, /api/walk/stop with no token, a wrong token, " \
               f"the token without 'Bearer': {answers}"

    def daemon_banner(self):
        self.driver.get(self.base + "/")
        banner = self.driver.find_element(By.ID, "daemon-banner")
        WebDriverWait(self.driver, 10).until(lambda d: banner.get_attribute("hidden"))
        code = self.processes.stop("monomeshd")
        WebDriverWait(self.driver, 15).until(
            lambda d: banner.is_displayed() and "daemon unreachable" in banner.text)
        status = http(self.base + "/api/status")[0]
        if status != 503:
            raise Failed(f"GET /api/status answers {status} with the daemon stopped")
        return f"monomeshd exited {code}; banner {banner.text!r}; /api/status 503"

    def run(self):
        try:
            self.setup()
            print(f"entry {self.entry}; monomesh-web at {self.base}", flush=True)
        except Exception as e:
            self.failures.append("setup")
            print(f"CHECK FAILED setup: {e}", flush=True)
            return
        self.check("entries_listed", self.entries_listed)
        self.check("downloads", self.downloads)
        self.check("status_panel", self.status_panel)
        self.check("viewer_loaded", self.viewer_loaded)
        if "viewer_loaded" not in self.failures:
            self.check("viewer_orbit", self.viewer_orbit)
        self.check("viewer_error", self.viewer_error)
        self.check("capture_refused", self.capture_refused)
        self.check("capture_live", self.capture_live)
        self.check("walk_live", self.walk_live)
        self.check("walk_viewer", self.walk_viewer)
        self.check("post_401", self.post_401)
        self.check("daemon_banner", self.daemon_banner)

    def finish(self):
        if self.driver and self.failures:
            try:
                print("----- browser console")
                for line in self.driver.get_log("browser"):
                    print(f"{line['level']} {line['message']}")
            except Exception as e:
                print(f"(no browser log: {e})")
        if self.driver:
            self.driver.quit()
        self.processes.stop_all()
        if self.failures:
            self.processes.print_logs()
            print(f"FAILED: {', '.join(self.failures)}")
            return 1
        print("all checks passed")
        return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--web-bin", required=True, help="monomesh-web")
    parser.add_argument("--daemon-bin", required=True, help="monomeshd")
    parser.add_argument("--ctl-bin", required=True, help="monomesh (for `monomesh ctl`)")
    parser.add_argument("--data", required=True, help="the dataset folder with calib.toml")
    parser.add_argument("--out", required=True, help="work folder (config, spool, logs, PNGs)")
    parser.add_argument("--screenshots-to", help="also copy status/entries/viewer PNGs here")
    args = parser.parse_args()
    for program in ("chromium", "chromedriver"):
        if not shutil.which(program):
            print(f"SKIP: no {program} (apt-get install chromium chromium-driver)")
            return SKIP
    test = Test(args)
    try:
        test.run()
    finally:
        code = test.finish()
    return code


if __name__ == "__main__":
    sys.exit(main())
