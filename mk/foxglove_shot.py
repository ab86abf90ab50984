#!/usr/bin/env python3
"""A screenshot of the Foxglove-protocol viewer app showing `mfns live` (docs/robotics.md
"Live"): docs/img/foxglove-view.png. Not part of `make test`: it needs a built web app.

    .venv/bin/python mk/foxglove_shot.py APP_DIR [-o docs/img/foxglove-view.png]

APP_DIR is a built web app that speaks the Foxglove WebSocket protocol and takes Foxglove's
URL parameters (ds=foxglove-websocket, ds.url, layoutUrl): Lichtblick's `yarn web:build:prod`
output (web/.webpack), the maintained open-source continuation of Foxglove Studio; the
vendor's Foxglove app is a hosted web site. What it does:
  1. flies a module run (mfns sim nav --scenario module, mfns table build, the built mfns-nav
     on the frames, mfns-ground on its telemetry: `make BOARD=host-sim flight lib` first);
  2. serves APP_DIR and ground/foxglove/mfns-layout.json on 127.0.0.1 (http.server);
  3. starts `mfns live --loop` on the flown run, opens the app in headless Chromium (its
     DevTools protocol, through `websockets`) with the URL that connects to
     ws://127.0.0.1:PORT and loads the layout, and waits until the status panel shows the
     navigation's diagnostics;
  4. closes the left sidebar, streams --seconds more, takes the screenshot (quantised to a
     palette to stay small) and prints the browser console's last warnings and errors.
Chromium composites the page in software (--disable-gpu-compositing): with GPU compositing
through SwiftShader, Page.captureScreenshot got no frame in minutes once the 3D panels drew.
"""

from __future__ import annotations

import argparse
import base64
import functools
import io
import json
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.parse
import urllib.request
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
LAYOUT = REPO / "ground" / "foxglove" / "mfns-layout.json"
BIN = REPO / "build" / "host-sim" / "bin"
HOST = "127.0.0.1"
WIDTH, HEIGHT = 1440, 810
APP_LOAD_TIMEOUT_S = 180  # the app's bundle is large and WebGL runs in software (SwiftShader)
CDP_TIMEOUT_S = 60
SHOT_TIMEOUT_S = 90  # software WebGL on a loaded machine draws slowly


def mfns(*args: str) -> None:
    r = subprocess.run([sys.executable, "-m", "mfns", *args], capture_output=True, text=True, check=False)
    if r.returncode != 0:
        sys.exit(f"mfns {' '.join(args)}: {r.stderr.strip()}")


def fly(work: Path, frames_n: int, seed: int) -> tuple[Path, Path]:
    """A flown module run: (ground folder, table)."""
    frames, table, tlm, ground = work / "frames", work / "table.mfnstbl", work / "tlm.bin", work / "ground"
    mfns(
        "sim",
        "nav",
        str(frames),
        "--quiet",
        "--scenario",
        "module",
        "--frames",
        str(frames_n),
        "--seed",
        str(seed),
    )
    mfns("table", "build", str(frames / "calib.json"), str(frames / "beacons.csv"), "-o", str(table), "-q")
    for cmd in (
        [str(BIN / "mfns-nav"), "--table", str(table), "--replay", str(frames), "--tlm-file", str(tlm)],
        [str(BIN / "mfns-ground"), "--file", str(tlm), "--out", str(ground), "--no-status"],
    ):
        r = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if r.returncode != 0:
            sys.exit(f"{cmd[0]}: {r.stderr.strip()}")
        print(r.stderr.strip().splitlines()[-1])
    return ground, table


def free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return int(s.getsockname()[1])


class Handler(SimpleHTTPRequestHandler):
    """The app's files, and the layout at /mfns-layout.json."""

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        if self.path.split("?")[0] == "/mfns-layout.json":
            data = self.server.layout.read_bytes()  # type: ignore[attr-defined]
            self.send_response(200)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)
            return
        super().do_GET()

    def log_message(self, format: str, *args) -> None:  # noqa: A002 (http.server's name)
        pass


class Cdp:
    """One page of Chromium through the DevTools protocol: call(method, params) -> result;
    console errors and exceptions are kept in `errors`."""

    def __init__(self, ws_url: str) -> None:
        from websockets.sync.client import connect

        self._conn = connect(ws_url, max_size=64 * 1024 * 1024, open_timeout=CDP_TIMEOUT_S)
        self.ws = self._conn.__enter__()
        self.next_id = 0
        self.errors: list[str] = []

    def _event(self, msg: dict) -> None:
        m, p = msg.get("method"), msg.get("params", {})
        if m == "Runtime.exceptionThrown":
            self.errors.append(
                "exception: "
                + p["exceptionDetails"].get("text", "")
                + " "
                + str(p["exceptionDetails"].get("exception", {}).get("description", ""))[:300]
            )
        elif m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "warning"):
            text = " ".join(str(a.get("value", a.get("description", ""))) for a in p.get("args", []))
            self.errors.append(f"console.{p['type']}: {text[:300]}")

    def call(self, method: str, params: dict | None = None, timeout: float = CDP_TIMEOUT_S) -> dict:
        self.next_id += 1
        self.ws.send(json.dumps({"id": self.next_id, "method": method, "params": params or {}}))
        while True:
            msg = json.loads(self.ws.recv(timeout=timeout))
            if msg.get("id") == self.next_id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})
            self._event(msg)

    def pump(self, seconds: float) -> None:
        """Read events for `seconds` (keeps the console log)."""
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            try:
                self._event(json.loads(self.ws.recv(timeout=left)))
            except TimeoutError:
                return

    def eval(self, expr: str):
        r = self.call("Runtime.evaluate", {"expression": expr, "returnByValue": True}, timeout=SHOT_TIMEOUT_S)
        return r.get("result", {}).get("value")


def chromium(profile: Path) -> tuple[subprocess.Popen, str]:
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        sys.exit("no chromium (mk/deps.sh test installs it)")
    proc = subprocess.Popen(
        [
            exe,
            "--headless=new",
            "--no-sandbox",
            "--no-first-run",
            "--disable-dev-shm-usage",
            "--disable-breakpad",
            "--disable-crash-reporter",
            "--use-angle=swiftshader",  # WebGL without a GPU, for the 3D panels
            "--enable-unsafe-swiftshader",
            "--disable-renderer-backgrounding",
            "--disable-gpu-compositing",  # the page composited in software: a shot needs no GPU frame
            "--disable-gpu-rasterization",
            "--ignore-gpu-blocklist",
            f"--window-size={WIDTH},{HEIGHT}",
            f"--user-data-dir={profile}",
            "--remote-debugging-port=0",
            "about:blank",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    port_file = profile / "DevToolsActivePort"
    end = time.monotonic() + CDP_TIMEOUT_S
    while not port_file.is_file() or not port_file.read_text().strip():
        if time.monotonic() > end or proc.poll() is not None:
            proc.kill()
            sys.exit("chromium did not start its DevTools endpoint")
        time.sleep(0.2)
    port = port_file.read_text().split()[0]
    pages = json.loads(urllib.request.urlopen(f"http://{HOST}:{port}/json/list", timeout=10).read())
    page = next(p for p in pages if p.get("type") == "page")
    return proc, page["webSocketDebuggerUrl"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("app", type=Path, help="the built web app's folder (Lichtblick: web/.webpack)")
    ap.add_argument("-o", "--out", type=Path, default=REPO / "docs" / "img" / "foxglove-view.png")
    ap.add_argument("--seconds", type=float, default=10.0, help="stream this long after the first data")
    ap.add_argument("--pace", type=float, default=0.15, help="mfns live --pace (the run lasts 6 s at 1)")
    ap.add_argument("--frames", type=int, default=120, help="frames of the module run")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--layout", type=Path, default=LAYOUT, help="the layout the app loads (layoutUrl)")
    ap.add_argument("--keep", type=Path, help="keep the flown run and the raw screenshot in this folder")
    args = ap.parse_args()
    if not (args.app / "index.html").is_file():
        sys.exit(f"{args.app}: no index.html (build the app first, see docs/robotics.md)")
    tmp = tempfile.TemporaryDirectory(prefix="mfns-fgshot-")
    work = args.keep or Path(tmp.name)
    work.mkdir(parents=True, exist_ok=True)
    ground, table = fly(work, args.frames, args.seed)

    httpd = ThreadingHTTPServer((HOST, 0), functools.partial(Handler, directory=str(args.app)))
    httpd.layout = args.layout  # type: ignore[attr-defined]
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    http = f"http://{HOST}:{httpd.server_address[1]}"
    ws_port = free_port()
    query = urllib.parse.urlencode(
        {
            "openIn": "web",
            "ds": "foxglove-websocket",
            "ds.url": f"ws://{HOST}:{ws_port}",
            "layoutUrl": f"{http}/mfns-layout.json",
        }
    )
    url = f"{http}/?{query}"
    print(f"app: {url}")

    profile = Path(tempfile.mkdtemp(prefix="mfns-fgshot-chromium-"))
    browser, page_ws = chromium(profile)
    live = None
    try:
        cdp = Cdp(page_ws)
        cdp.call("Runtime.enable")
        cdp.call("Page.enable")
        cdp.call(
            "Emulation.setDeviceMetricsOverride",
            {"width": WIDTH, "height": HEIGHT, "deviceScaleFactor": 1, "mobile": False},
        )
        live = subprocess.Popen(  # first: the app connects at once (it retries with back-off)
            [
                sys.executable,
                "-m",
                "mfns",
                "live",
                str(ground),
                "--table",
                str(table),
                "--port",
                str(ws_port),
                "--pace",
                str(args.pace),
                "--loop",
                "--max-seconds",
                str(APP_LOAD_TIMEOUT_S + args.seconds + 120),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert live.stdout is not None
        print(live.stdout.readline().strip())
        cdp.call("Page.navigate", {"url": url})
        t0 = time.monotonic()
        # data have arrived: the diagnostics panels wait no more ("Waiting for /diagnostics")
        ready_js = "!!document.querySelector('canvas') && !document.body.innerText.includes('Waiting for')"
        while not cdp.eval(ready_js):
            if time.monotonic() - t0 > APP_LOAD_TIMEOUT_S:
                sys.exit(f"no navigation status shown in {APP_LOAD_TIMEOUT_S} s: {cdp.errors[-5:]}")
            cdp.pump(3.0)
        print(f"app connected and showing data in {time.monotonic() - t0:.1f} s")
        cdp.eval("document.querySelector('[data-testid=left-sidebar-button]')?.click()")  # room
        cdp.pump(args.seconds)
        t1 = time.monotonic()
        try:
            shot = base64.b64decode(
                cdp.call("Page.captureScreenshot", {"format": "png"}, timeout=SHOT_TIMEOUT_S)["data"]
            )
        except TimeoutError:
            sys.exit(f"Page.captureScreenshot: no answer in {SHOT_TIMEOUT_S} s (GPU compositing on?)")
        print(f"shot taken in {time.monotonic() - t1:.1f} s")
        title = cdp.eval("document.title")
    finally:
        if live is not None:
            live.terminate()
            out, err = live.communicate(timeout=30)
            print((out + err).strip())
        browser.terminate()
        browser.wait(timeout=30)
        shutil.rmtree(profile, ignore_errors=True)
        httpd.shutdown()
    if args.keep:
        (args.keep / "raw.png").write_bytes(shot)
    from PIL import Image

    img = Image.open(io.BytesIO(shot)).convert("RGB").quantize(colors=128, method=Image.Quantize.MEDIANCUT)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    img.save(args.out, optimize=True)
    print(f"{args.out}: {args.out.stat().st_size} bytes, page title {title!r}")
    for e in cdp.errors[-15:]:
        print("  browser:", e)
    return 0


if __name__ == "__main__":
    sys.exit(main())
