"""What the web tests share (tests/web/browser_test.py, tests/web/load_test.py): the config for
monomeshd and monomesh-web on a dataset, the two processes, plain HTTP, waiting."""
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import traceback
import urllib.error
import urllib.request

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
STATIC_DIR = os.path.join(REPO, "web", "static")
THREE_DIR = "/usr/share/javascript/three"


class Failed(Exception):
    pass


class Exited(Exception):
    """A process the test started is gone (wait_for does not wait on)."""


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def http(url, method="GET", headers=None, timeout=10):
    """(status, headers, body) of one request; an HTTP error answer is returned, not raised."""
    request = urllib.request.Request(url, method=method, headers=headers or {},
                                     data=b"" if method == "POST" else None)
    try:
        with urllib.request.urlopen(request, timeout=timeout) as answer:
            return answer.status, answer.headers, answer.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers, e.read()


def get_json(url):
    status, _, body = http(url)
    if status != 200:
        raise Failed(f"GET {url}: {status} {body[:200]!r}")
    return json.loads(body)


def wait_for(what, predicate, timeout_s, period_s=0.2):
    """predicate()'s first truthy value within the time, else Failed naming `what`."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            value = predicate()
        except (OSError, ValueError, Failed):
            value = None
        if value:
            return value
        if time.monotonic() > deadline:
            raise Failed(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(period_s)


class Processes:
    """monomeshd and monomesh-web, their logs in the work folder; stopped with SIGTERM."""

    def __init__(self, out):
        self.out = out
        self.procs = {}  # name -> (Popen, log path)

    def start(self, name, argv):
        log_path = os.path.join(self.out, f"{name}.log")
        log = open(log_path, "wb")
        self.procs[name] = (subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT), log_path)
        log.close()

    def alive(self, name):
        """True while it runs; Exited once it is gone."""
        code = self.procs[name][0].poll()
        if code is not None:
            raise Exited(f"{name} exited {code} (log: {self.procs[name][1]})")
        return True

    def stop(self, name, timeout_s=60):
        proc = self.procs[name][0]
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(timeout_s)  # a pair being reconstructed is finished first
            except subprocess.TimeoutExpired:
                print(f"{name} did not stop within {timeout_s} s; killed", flush=True)
                proc.kill()
                proc.wait()
        return proc.returncode

    def stop_all(self):
        for name in reversed(list(self.procs)):
            self.stop(name)

    def print_logs(self):
        for name, (proc, log_path) in self.procs.items():
            print(f"----- {name} (exit {proc.returncode}) log: {log_path}")
            with open(log_path, errors="replace") as f:
                lines = f.readlines()
            sys.stdout.writelines(lines[-200:])
        sys.stdout.flush()


def write_config(args, out, port, token):
    spool = os.path.join(out, "spool")
    shutil.rmtree(spool, ignore_errors=True)  # only this run's entries
    socket_path = os.path.join(out, "control.sock")
    token_file = os.path.join(out, "web-token")
    with open(token_file, "w") as f:
        f.write(token + "\n")
    os.chmod(token_file, 0o600)
    data = os.path.abspath(args.data)
    config = os.path.join(out, "monomeshd.toml")
    q = json.dumps  # a TOML basic string, quoted and escaped
    with open(config, "w") as f:
        f.write(f"""# Written by the web tests (tests/web): the bundled dataset as a camera at 1x speed.
[camera]
uri = {q(f"replay:{data}?rate=realtime&loop=1")}
calibration = {q(os.path.join(data, "calib.toml"))}
[control]
socket = {q(socket_path)}
group = ""
[spool]
dir = {q(spool)}
[web]
listen = "127.0.0.1:{port}"
token_file = {q(token_file)}
static_dir = {q(STATIC_DIR)}
three_dir = {q(THREE_DIR)}
""")
    return config, socket_path




def run_check(failures, name, function, expected=(Failed,)):
    """Runs one check: prints `CHECK ok NAME: detail` or `CHECK FAILED NAME: why` (with a
    traceback for an exception other than `expected`) and appends a failure's name."""
    try:
        detail = function()
        print(f"CHECK ok {name}" + (f": {detail}" if detail else ""), flush=True)
    except Exception as e:  # a check's failure of any kind is reported, the others go on
        failures.append(name)
        print(f"CHECK FAILED {name}: {e}", flush=True)
        if not isinstance(e, expected):
            traceback.print_exc(file=sys.stdout)
