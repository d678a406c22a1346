"""MAVLink transport: the pymavlink connection, GCS heartbeat, telemetry log, stream upkeep.

Connection strings are pymavlink's: ``udpin:0.0.0.0:14550`` (listen; what ArduPilot SITL's
``--out=udp:127.0.0.1:14550`` talks to), ``udpout:192.168.1.10:14550``, ``tcp:127.0.0.1:5760``
(SITL's first serial port), ``/dev/ttyACM0,115200`` (USB / telemetry radio, baud after the comma).

- :class:`MavTransport` opens the connection, runs the receive thread (every message goes to a
  handler) and a 1 Hz GCS HEARTBEAT, and records the session as a ``.tlog`` (pymavlink's own
  log format: 8-byte big-endian microsecond timestamp + the MAVLink packet, received messages
  through pymavlink's ``setup_logfile`` (its UDP path skips that file, so UDP messages are
  appended by the receive thread), sent ones through the encoder's send callback; Mission
  Planner, QGroundControl, MAVExplorer and ``mavutil.mavlink_connection(path)`` read it);
- :class:`StreamKeeper` keeps the telemetry streams flowing: ``MAV_CMD_SET_MESSAGE_INTERVAL``
  checked by its COMMAND_ACK, falling back to ``REQUEST_DATA_STREAM`` when the vehicle refuses it,
  and re-requested whenever a stream stops (after a reboot the vehicle forgets the rates); it also
  reads the EKF origin (GPS_GLOBAL_ORIGIN) and the failsafe parameters.
"""

from __future__ import annotations

import hashlib
import logging
import math
import re
import struct
import threading
import time
from pathlib import Path
from typing import Any, Callable

from console.link.base import CommandRejected, LinkError
from console.link.mavlink_telemetry import TRACKED, Telemetry

log = logging.getLogger(__name__)

_URL_RE = re.compile(r"^(udpin|udpout|udp|udpbcast|tcp|tcpin):([^:]+):(\d+)$")

FAILSAFE_PARAMS = ("FS_GCS_ENABLE", "FS_GCS_TIMEOUT", "FS_EKF_ACTION", "SYSID_MYGCS", "MAV_GCS_SYSID")
"""ArduPilot Copter failsafe parameters read at connect; the GCS failsafe counts only heartbeats from system
``SYSID_MYGCS`` (``MAV_GCS_SYSID`` from ArduPilot 4.7; ArduCopter GCS_Mavlink.cpp / events.cpp)."""

ASKS = 5
"""How often the EKF origin and the failsafe parameters are asked for (per connection / reboot): an
indoor vehicle may have no origin, other firmware no such parameters."""

DATA_STREAMS = {"EXTENDED_STATUS": 2, "POSITION": 6, "EXTRA1": 10, "EXTRA3": 12}
"""REQUEST_DATA_STREAM groups (MAV_DATA_STREAM) carrying SYS_STATUS, LOCAL_POSITION_NED, ATTITUDE,
EXTENDED_SYS_STATE / EKF_STATUS_REPORT in ArduPilot."""


def mavutil() -> Any:
    from pymavlink import mavutil as m

    return m


def parse_connection(url: str) -> tuple[str, int | None]:
    """Check a pymavlink connection string; returns ``(device, baud or None)``.

    Raises:
        LinkError: The string is not ``udpin|udpout|udp|tcp|tcpin:HOST:PORT`` nor a serial device
            with an optional ``,BAUD``.
    """
    text = url.strip()
    if not text:
        raise LinkError("empty MAVLink connection string")
    m = _URL_RE.match(text)
    if m:
        port = int(m.group(3))
        if port > 65535:
            raise LinkError(f"MAVLink connection {url!r}: port {port} is out of range")
        return text, None
    if re.match(r"^[a-z]+:", text) and not re.match(r"^[A-Za-z]:[\\/]", text):
        raise LinkError(
            f"MAVLink connection {url!r}: expected udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, "
            "tcpin:HOST:PORT or a serial device like /dev/ttyACM0,115200")
    device, _, baud_text = text.partition(",")
    baud: int | None = None
    if baud_text:
        try:
            baud = int(baud_text)
        except ValueError:
            raise LinkError(f"MAVLink connection {url!r}: baud rate {baud_text!r} is not a number") from None
        if baud <= 0:
            raise LinkError(f"MAVLink connection {url!r}: baud rate must be > 0")
    if not (device.startswith("/") or device.upper().startswith("COM")):
        raise LinkError(f"MAVLink connection {url!r}: not a udp/tcp address nor a serial device path")
    return device, baud


def tlog_path(tlog: str | Path) -> Path:
    """A folder -> ``<folder>/mavlink-YYYYmmdd-HHMMSS.tlog``; a ``.tlog`` file path as is."""
    p = Path(tlog)
    if p.suffix == ".tlog":
        p.parent.mkdir(parents=True, exist_ok=True)
        return p
    p.mkdir(parents=True, exist_ok=True)
    return p / time.strftime("mavlink-%Y%m%d-%H%M%S.tlog")


def signing_secret(key: str) -> bytes:
    """The 32-byte MAVLink 2 signing key: 64 hex digits as they are, else SHA-256 of the passphrase
    (as MAVProxy's ``signing setup PASSPHRASE``)."""
    text = key.strip()
    if re.fullmatch(r"[0-9a-fA-F]{64}", text):
        return bytes.fromhex(text)
    return hashlib.sha256(text.encode()).digest()


def use_mavlink2() -> None:
    """Switch pymavlink to MAVLink 2 before a connection opens (signing needs it; a connection that
    switched by itself on the first MAVLink 2 packet would lose its signing set-up)."""
    import os

    if os.environ.get("MAVLINK20") != "1":
        os.environ["MAVLINK20"] = "1"
        mavutil().set_dialect("ardupilotmega")


class MavTransport:
    """The pymavlink connection with its receive and GCS-heartbeat threads.

    On a stream transport (TCP) nothing but our heartbeat is written while the vehicle has sent nothing
    at all for longer than ``gate_after`` (the link's ``min(heartbeat_timeout, pose_timeout)``): what is
    written into a blocked TCP connection waits there and reaches
    the vehicle late (seconds to minutes), so such a send raises :class:`LinkError` instead. With a
    ``signing_key`` every message is signed (MAVLink 2); unsigned or wrongly signed messages from the
    vehicle are still read (and counted: ``bad_signatures``). Once a second the heartbeat thread also
    sends a TIMESYNC request (the vehicle's answer gives the round-trip time).

    Args:
        url: pymavlink connection string.
        source_system, source_component: Our MAVLink ids (255 / 190: a GCS).
        on_message: Called on the receive thread with every decoded message.
        tlog: Folder or ``.tlog`` path to record the session to (``None``: no log).
    """

    def __init__(self, url: str, source_system: int, source_component: int, on_message: Callable[[Any], None],
                 tlog: str | Path | None = None, on_reconnect: Callable[[str], None] | None = None,
                 silence: Callable[[], float] | None = None, gate_after: float = math.inf,
                 signing_key: str | None = None, on_timesync: Callable[[int], None] | None = None) -> None:
        self.url = url
        self.silence, self.gate_after = silence, gate_after
        self.signing_key = signing_key
        self.on_timesync = on_timesync
        self.stream = url.strip().startswith(("tcp:", "tcpin:"))
        self.gated = 0  # sends refused on a silent stream transport
        self.device, self.baud = parse_connection(url)
        self.source_system, self.source_component = source_system, source_component
        self.on_message = on_message
        self.on_reconnect = on_reconnect  # called when pymavlink replaced the socket (TCP reconnect)
        self.tlog_request = tlog
        self.tlog: Path | None = None
        self.conn: Any = None
        self.stop = threading.Event()
        self._send_lock = threading.Lock()
        self._hb_now = threading.Event()
        self._threads: list[threading.Thread] = []
        self.sent = 0
        self._log_received = False

    @property
    def bad_signatures(self) -> int:
        """Messages whose signature did not match our key."""
        conn = self.conn
        return int(getattr(getattr(getattr(conn, "mav", None), "signing", None), "badsig_count", 0) or 0)

    @property
    def is_open(self) -> bool:
        return self.conn is not None and not self.stop.is_set()

    @property
    def local_port(self) -> int | None:
        """Our UDP/TCP port (useful with ``udpin:127.0.0.1:0``), or ``None``."""
        try:
            return int(self.conn.port.getsockname()[1])
        except Exception:
            return None

    def open(self) -> None:
        if self.conn is not None:
            return
        kwargs: dict[str, Any] = {"source_system": self.source_system, "source_component": self.source_component,
                                  "autoreconnect": True}
        if self.baud is not None:
            kwargs["baud"] = self.baud
        if self.signing_key is not None:
            use_mavlink2()
        try:
            self.conn = mavutil().mavlink_connection(self.device, **kwargs)
        except ImportError as exc:  # pymavlink imports pyserial only for serial devices
            raise LinkError(f"serial MAVLink connections need pyserial (pip install pyserial): {exc}") from None
        except (OSError, ValueError) as exc:
            raise LinkError(f"cannot open MAVLink connection {self.url!r}: {exc}") from None
        if self.signing_key is not None:
            self.conn.setup_signing(signing_secret(self.signing_key), sign_outgoing=True,
                                    allow_unsigned_callback=lambda _mav, _msg_id: True)
        if self.tlog_request is not None:
            try:
                self.tlog = tlog_path(self.tlog_request)
                self.conn.setup_logfile(str(self.tlog))  # received messages, timestamped by pymavlink
                self.conn.mav.set_send_callback(self._log, "sent")  # and what we send
                # pymavlink's UDP receive path skips the logfile: those messages are written here
                self._log_received = type(self.conn).recv_msg is not mavutil().mavfile.recv_msg
            except OSError as exc:
                log.error("cannot record the MAVLink session to %s: %s", self.tlog_request, exc)
                self.tlog = None
        self.stop.clear()
        for target, name in ((self._rx_loop, "mav-rx"), (self._heartbeat_loop, "mav-heartbeat")):
            t = threading.Thread(target=target, name=name, daemon=True)
            t.start()
            self._threads.append(t)

    def _log(self, msg: Any, why: str = "received") -> None:
        """Append one message to the .tlog (8-byte big-endian microseconds + the packet)."""
        f = getattr(self.conn, "logfile", None)
        if f is not None:
            try:
                f.write(struct.pack(">Q", int(time.time() * 1.0e6) & ~3) + msg.get_msgbuf())
            except (OSError, ValueError):
                pass

    def close(self) -> None:
        self.stop.set()
        self._hb_now.set()
        for t in self._threads:
            if t.is_alive() and t is not threading.current_thread():  # a close racing connect: maybe not started
                t.join(timeout=2.0)
        self._threads = []
        conn, self.conn = self.conn, None
        if conn is not None:
            try:
                conn.close()
            except Exception:
                pass
            f = getattr(conn, "logfile", None)
            if f is not None:
                try:
                    f.close()
                except Exception:
                    pass

    def send(self, fn_name: str, *args: Any) -> None:
        """Call ``conn.mav.<fn_name>(*args)`` (e.g. ``command_long_send``)."""
        conn = self.conn
        if conn is None:
            raise LinkError("MAVLink link is not open")
        if self.stream and fn_name != "heartbeat_send" and self.silence is not None:
            quiet = self.silence()
            if quiet > self.gate_after:
                self.gated += 1
                raise LinkError(f"not sent: the vehicle has been silent for {quiet:.1f} s on {self.url}; on TCP the "
                                "message would wait in the connection and reach the vehicle late")
        with self._send_lock:
            try:
                getattr(conn.mav, fn_name)(*args)
            except OSError as exc:
                raise LinkError(f"MAVLink send failed on {self.url}: {exc}") from None
            self.sent += 1

    def heartbeat_now(self) -> None:
        self._hb_now.set()

    def _heartbeat_loop(self) -> None:
        mav = mavutil().mavlink
        while not self.stop.is_set():
            self._hb_now.wait(1.0)
            self._hb_now.clear()
            if self.stop.is_set():
                return
            try:
                self.send("heartbeat_send", mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, mav.MAV_STATE_ACTIVE)
                if self.on_timesync is not None:
                    ts1 = time.monotonic_ns()
                    self.on_timesync(ts1)
                    self.send("timesync_send", 0, ts1)
            except Exception as exc:  # a closed socket while shutting down, a gated TCP link
                log.debug("heartbeat not sent: %s", exc)

    def _rx_loop(self) -> None:
        port = None
        while not self.stop.is_set():
            conn = self.conn
            if conn is None:
                return
            now_port = getattr(conn, "port", None)
            if port is not None and now_port is not None and now_port is not port and self.on_reconnect:
                self.on_reconnect(f"transport reconnected ({self.url})")
            port = now_port if now_port is not None else port
            try:
                msg = conn.recv_match(blocking=True, timeout=0.05)
            except Exception as exc:  # socket closed under us, serial unplugged
                if self.stop.is_set():
                    return
                log.warning("MAVLink receive error on %s: %s", self.url, exc)
                self.stop.wait(0.2)
                continue
            if msg is not None:
                if self._log_received and msg.get_type() != "BAD_DATA":
                    self._log(msg)
                try:
                    self.on_message(msg)
                except Exception:  # one odd message must not stop the link
                    log.exception("MAVLink message %s not handled", msg.get_type())


class StreamKeeper:
    """Keeps LOCAL_POSITION_NED / ATTITUDE / EXTENDED_SYS_STATE / SYS_STATUS flowing.

    Args:
        rate: Wanted rate [Hz] (0: leave the vehicle's rates alone, still read origin/params).
        telemetry: Where stream ages come from.
        transport: For fire-and-forget requests.
        command: ``command(cmd, params, what, retries)`` sending a COMMAND_LONG and waiting for its
            ACK (raises :class:`CommandRejected` / :class:`LinkError`).
        target: Returns the vehicle's ``(system, component)``.
        stale_after: A stream silent this long is requested again [s].
        retry_period: Minimum time between two requests of one stream [s].
    """

    def __init__(self, rate: float, telemetry: Telemetry, transport: MavTransport,
                 command: Callable[..., None], target: Callable[[], tuple[int, int]],
                 stale_after: float = 1.0, retry_period: float = 2.0) -> None:
        self.rate, self.tel, self.transport = rate, telemetry, transport
        self.command, self.target = command, target
        self.stale_after, self.retry_period = stale_after, retry_period
        self.method = "interval"  # or "data_stream" once SET_MESSAGE_INTERVAL is refused
        self.requests: dict[str, int] = {}  # stream -> requests sent
        self._last: dict[str, float] = {}
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._origin_asked = 0.0
        self._params_asked = 0.0
        self._asks = {"origin": 0, "params": 0}  # per epoch: a vehicle without an origin / those parameters
        self.want_origin = True

    def start(self) -> None:
        self._thread = threading.Thread(target=self._loop, name="mav-streams", daemon=True)
        self._thread.start()

    def join(self) -> None:
        self._wake.set()
        if self._thread is not None and self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=3.0)

    def renew(self) -> None:
        """After a reboot / reconnect: request everything again now and re-read the origin."""
        self._last.clear()
        with self.tel.lock:
            self.tel.v.origin_now = None  # re-read: a rebooted vehicle sets a new EKF origin
        self.want_origin = True
        self._origin_asked = 0.0
        self._asks = {"origin": 0, "params": 0}
        self._wake.set()

    def _loop(self) -> None:
        while not self.transport.stop.is_set():
            try:
                self.check()
            except LinkError as exc:
                log.debug("stream upkeep: %s", exc)
            except Exception:
                log.exception("stream upkeep failed")
            self._wake.wait(0.25)
            self._wake.clear()

    def check(self) -> None:
        """One round: re-request stale streams, read origin and failsafe parameters."""
        now = time.monotonic()
        if self.tel.silence() > min(0.25, self.stale_after / 2):
            return  # only a vehicle heard just now is asked (a silent one on TCP would get it late); next round
        if self.rate > 0:
            stale = [k for k in TRACKED if self.tel.stream_age(k) > self.stale_after
                     and now - self._last.get(k, -math.inf) >= self.retry_period]
            for k in stale:
                if self.transport.stop.is_set():
                    return
                self._request(k)
        self._housekeeping(now)

    def _request(self, kind: str) -> None:
        mav = mavutil().mavlink
        self._last[kind] = time.monotonic()
        self.requests[kind] = self.requests.get(kind, 0) + 1
        if self.method == "interval":
            msg_id = getattr(mav, f"MAVLINK_MSG_ID_{kind}")
            try:
                self.command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, (msg_id, 1e6 / self.rate),
                             f"SET_MESSAGE_INTERVAL {kind}", retries=1)
                return
            except CommandRejected as exc:
                log.warning("%s: falling back to REQUEST_DATA_STREAM", exc)
                self.method = "data_stream"
                self.tel.warn("streams", "the vehicle refused MAV_CMD_SET_MESSAGE_INTERVAL "
                                         f"({str(exc).split(': ')[-1]}): telemetry requested with REQUEST_DATA_STREAM")
            except LinkError as exc:  # no ACK: ask the old way too this time
                log.info("%s: also sending REQUEST_DATA_STREAM", exc)
        sys_id, comp = self.target()
        for stream in DATA_STREAMS.values():
            self.transport.send("request_data_stream_send", sys_id, comp, stream, max(1, round(self.rate)), 1)

    def _housekeeping(self, now: float) -> None:
        mav = mavutil().mavlink
        try:
            sys_id, comp = self.target()
        except LinkError:
            return
        with self.tel.lock:
            have_origin = self.tel.v.origin_now is not None
            missing = [p for p in FAILSAFE_PARAMS if p not in self.tel.v.params]
        if have_origin:
            self.want_origin = False
            self.tel.clear_warning("origin_unset")
        elif self._asks["origin"] >= ASKS and now - self._origin_asked > self.retry_period:
            # GCS_Common.cpp: REQUEST_MESSAGE is ACCEPTED, but GPS_GLOBAL_ORIGIN is sent only once the origin is set
            self.tel.warn("origin_unset", f"the vehicle reports no EKF origin (GPS_GLOBAL_ORIGIN asked {ASKS} times, "
                                          "never sent): ArduPilot sets it with a GPS fix or SET_GPS_GLOBAL_ORIGIN; "
                                          "until then a moved origin cannot be detected")
        if self.want_origin and now - self._origin_asked > self.retry_period and self._asks["origin"] < ASKS:
            self._origin_asked = now
            self._asks["origin"] += 1
            self.transport.send("command_long_send", sys_id, comp, mav.MAV_CMD_REQUEST_MESSAGE, 0,
                                mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, 0, 0, 0, 0, 0, 0)
        if missing and now - self._params_asked > self.retry_period and self._asks["params"] < ASKS:
            self._params_asked = now
            self._asks["params"] += 1
            for name in missing:
                self.transport.send("param_request_read_send", sys_id, comp, name.encode(), -1)
        with self.tel.lock:
            fs = self.tel.v.params.get("FS_GCS_ENABLE")
        if fs is not None and fs == 0:
            self.tel.warn("fs_gcs", "FS_GCS_ENABLE is 0: the vehicle's own GCS failsafe is off; when the link "
                                    "is lost only the console's commands (if they get through) stop the vehicle")
        elif fs is not None:
            self.tel.clear_warning("fs_gcs")
        self._check_gcs_id(fs)

    def _check_gcs_id(self, fs: float | None) -> None:
        """The vehicle's GCS failsafe ignores heartbeats from a system id other than its SYSID_MYGCS: with
        another id the console's link looks fine while the vehicle counts down to its failsafe."""
        with self.tel.lock:
            params = self.tel.v.params
            gcs_id = params.get("MAV_GCS_SYSID", params.get("SYSID_MYGCS"))
        ours = self.transport.source_system
        if gcs_id is not None and int(gcs_id) != ours and fs != 0:
            self.tel.warn("gcs_sysid", f"the vehicle's SYSID_MYGCS (MAV_GCS_SYSID) is {int(gcs_id)}, the console is "
                                       f"system {ours}: the vehicle does not count the console's heartbeats, so "
                                       "its GCS failsafe triggers although the link works: set the parameter to "
                                       f"{ours}")
        elif gcs_id is not None:
            self.tel.clear_warning("gcs_sysid")


__all__ = ["MavTransport", "StreamKeeper", "parse_connection", "tlog_path", "FAILSAFE_PARAMS"]
