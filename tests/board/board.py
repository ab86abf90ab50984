"""The emulated sitss-nav board of tests/board: the image booted under
qemu-system-aarch64 (boards/sitss-nav/image/boot.sh), its console on a pipe, its
flight link on a host pty where mfns-ground (the host build) decodes the
telemetry, forwards every packet to a UDP socket this module reads, and sends
the commands written to its stdin, signed with the image's key.

Packets are decoded from the datagrams with the XTCE mission database through
space-packet-parser (the project's dictionary, no project C code on the way);
each one keeps the host's monotonic arrival time for the measurements.
"""

from __future__ import annotations

import re
import socket
import subprocess
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
IMAGE = REPO / "build" / "image"
GROUND = REPO / "build" / "host-sim" / "bin" / "mfns-ground"


@dataclass
class Packet:
    kind: str  # nav, camera, housekeeping, event, ... (the dictionary's names)
    fields: dict
    t: float  # host monotonic arrival time
    raw: bytes = field(repr=False, default=b"")


class Board:
    """One boot of the image (and its reboots), with a ground station attached."""

    def __init__(self, work: Path):
        from space_packet_parser.xtce.definitions import XtcePacketDefinition

        from mfns.tlm import tlm_dict

        self.work = work
        self.dict = tlm_dict.load()
        self.names = {p.apid: n for n, p in self.dict.packets.items()}
        self.event_names = self.dict.labels("event_code_t")
        self.event_codes = {v: k for k, v in self.event_names.items()}
        self.definition = XtcePacketDefinition.from_xtce(tlm_dict.mdb_path())
        self.packets: list[Packet] = []
        self.console: list[tuple[float, str]] = []
        self.lock = threading.Lock()
        self.t_start = 0.0
        self.qemu: subprocess.Popen | None = None
        self.ground: subprocess.Popen | None = None
        self.pty = ""
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind(("127.0.0.1", 0))
        self.udp.settimeout(0.2)
        self._stop = False
        self._threads: list[threading.Thread] = []

    # ------------------------------------------------------------------ start/stop
    def start(self, boot_timeout_s: float = 120.0) -> None:
        self.t_start = time.monotonic()
        frames = IMAGE / "frames.img"  # rendered LED frames for the board test's rig (mk/image.mk)
        self.qemu = subprocess.Popen(
            [str(REPO / "boards/sitss-nav/image/boot.sh"), str(IMAGE), str(self.work / "run")]
            + ([str(frames)] if frames.exists() else []),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            bufsize=0,
        )
        self._spawn(self._read_console)
        self._spawn(self._read_udp)
        m = self.wait_console(r"char device redirected to (/dev/pts/\d+) \(label uart\)", boot_timeout_s)
        self.pty = m.group(1)
        self.attach_ground("ground")

    def uplink_args(self) -> list[str]:
        """mfns-ground's link and uplink options for this board (one ground on the pty at a time)."""
        return [
            str(GROUND),
            "--tty",
            self.pty,
            "--uplink",
            "--tc-key",
            str(IMAGE / "tc.key"),
            "--tc-state",  # the ground gives the board its epochs (docs/uplink.md 1a)
            str(self.work / "ground-uplink.state"),
        ]

    def attach_ground(self, out: str) -> None:
        """The ground station that reads the link into work/OUT, forwards every packet to the
        test's UDP socket and sends the commands written to its stdin."""
        port = self.udp.getsockname()[1]
        self.ground = subprocess.Popen(
            self.uplink_args()
            + [
                "--cmd-file",
                "-",
                "--out",
                str(self.work / out),
                "--udp-forward",
                f"127.0.0.1:{port}",
                "--no-status",
                "-q",
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=open(self.work / f"{out}.err", "w"),
            bufsize=0,
        )

    def detach_ground(self) -> None:
        if self.ground is not None and self.ground.poll() is None:
            self.ground.stdin.close()
            self.ground.terminate()
            self.ground.wait(20)

    def stop(self) -> None:
        if self.ground is not None and self.ground.poll() is None:
            self.ground.stdin.close()
            self.ground.terminate()
            try:
                self.ground.wait(10)
            except subprocess.TimeoutExpired:
                self.ground.kill()
        if self.qemu is not None and self.qemu.poll() is None:
            self.qemu.terminate()
            try:
                self.qemu.wait(10)
            except subprocess.TimeoutExpired:
                self.qemu.kill()
        self._stop = True
        for t in self._threads:
            t.join(2)
        self.udp.close()
        with open(self.work / "console.log", "w") as f:
            f.writelines(f"{t - self.t_start:9.3f} {line}\n" for t, line in self.console)

    def _spawn(self, fn) -> None:
        t = threading.Thread(target=fn, daemon=True)
        t.start()
        self._threads.append(t)

    def _read_console(self) -> None:
        buf = b""
        while not self._stop:
            chunk = self.qemu.stdout.read(4096)
            if not chunk:
                break
            buf += chunk
            *lines, buf = buf.split(b"\n")
            now = time.monotonic()
            with self.lock:
                self.console.extend((now, ln.decode(errors="replace").rstrip("\r")) for ln in lines)

    def _read_udp(self) -> None:
        while not self._stop:
            try:
                data = self.udp.recv(65536)
            except TimeoutError:
                continue
            except OSError:
                break
            now = time.monotonic()
            try:
                packet, p = self.dict.parse_checked(self.definition, data)
                kind = self.names[packet.apid]
                p = self._fields(kind, p)
            except Exception as e:  # noqa: BLE001 -- an undecodable packet is recorded, the test fails on it
                apid = int.from_bytes(data[:2], "big") & 0x7FF if len(data) >= 2 else -1
                kind, p = (
                    "undecodable",
                    {"error": repr(e), "apid": apid, "bytes": len(data), "hex": data[:48].hex()},
                )
            with self.lock:
                self.packets.append(Packet(kind, dict(p), now, data))

    def _fields(self, kind: str, parsed) -> dict:
        """The dictionary's field names (the XTCE's carry the packet's prefix: evt_code -> code)."""
        known = {f.name for f in self.dict.packets[kind].fields}
        out = {}
        for k, v in dict(parsed).items():
            if k in known:
                out[k] = v
            else:
                tail = k.partition("_")[2]
                out[tail if tail in known else k] = v
        return out

    # ------------------------------------------------------------------ waiting
    def wait_console(self, pattern: str, timeout_s: float, since: float = 0.0) -> re.Match:
        return self.wait_console_at(pattern, timeout_s, since)[1]

    def wait_console_at(self, pattern: str, timeout_s: float, since: float = 0.0) -> tuple[float, re.Match]:
        """The first console line matching pattern, with the host monotonic time it was read."""
        rx = re.compile(pattern)
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self.lock:
                for t, line in self.console:
                    if t >= since:
                        m = rx.search(line)
                        if m:
                            return t, m
            if self.qemu.poll() is not None:
                break
            time.sleep(0.05)
        raise AssertionError(
            f"no console line matching {pattern!r} within {timeout_s} s\n" + self.console_tail()
        )

    def console_tail(self, n: int = 40) -> str:
        with self.lock:
            return "\n".join(line for _, line in self.console[-n:])

    def wait_packet(self, pred, timeout_s: float, since: float = 0.0, what: str = "packet") -> Packet:
        deadline = time.monotonic() + timeout_s
        seen = 0
        while time.monotonic() < deadline:
            with self.lock:
                new = self.packets[seen:]
                seen = len(self.packets)
            for p in new:
                if p.t >= since and pred(p):
                    return p
            time.sleep(0.02)
        raise AssertionError(f"no {what} within {timeout_s} s\n" + self.console_tail())

    def events(self, since: float = 0.0) -> list[Packet]:
        with self.lock:
            return [p for p in self.packets if p.kind == "event" and p.t >= since]

    def event_name(self, p: Packet) -> str:
        code = p.fields["code"]
        return code if isinstance(code, str) else self.event_names.get(int(code), str(code))

    def wait_event(self, name: str, timeout_s: float, since: float = 0.0, where=None) -> Packet:
        return self.wait_packet(
            lambda p: p.kind == "event" and self.event_name(p) == name and (where is None or where(p)),
            timeout_s,
            since,
            f"{name} event",
        )

    # ------------------------------------------------------------------ acting
    def shell(self, command: str) -> float:
        """Runs a command on the console's maintenance shell; returns the host time it was sent."""
        t = time.monotonic()
        self.qemu.stdin.write(b"\n" + command.encode() + b"\n")
        return t

    def command(self, text: str) -> float:
        """Sends one telecommand through mfns-ground; returns the host time it was sent."""
        t = time.monotonic()
        self.ground.stdin.write(text.encode() + b"\n")
        return t
