"""Live view in Foxglove: the recorded topics served over the Foxglove WebSocket protocol (``foxglove-sdk``).

Off by default (``morphonavi console --foxglove-ws PORT``). The :class:`~console.recording.recording.Recorder`
hands every message it writes to :meth:`LiveView.log` as well, on its writer thread; a client that
subscribes to a state topic (map, grid, paths, scene, route, mission, capture) is sent its latest
message at once, so the Foxglove app shows the current map without waiting for the next change.
Listens on 127.0.0.1 only. Open it in Foxglove with *Open connection* → Foxglove WebSocket →
``ws://127.0.0.1:PORT``.
"""

from __future__ import annotations

import logging
import threading
from typing import Any

from console.recording import recording_schemas as rs

log = logging.getLogger(__name__)


class LiveView:
    """A Foxglove WebSocket server on ``127.0.0.1:port`` (0 = any free port) with the recorder's topics."""

    def __init__(self, port: int = 8765) -> None:
        import foxglove

        if not (isinstance(port, int) and 0 <= port <= 65535):
            raise ValueError(f"foxglove_port: must be a TCP port within 0..65535, got {port!r}")
        self._fg = foxglove
        self._ctx = foxglove.Context()
        self._lock = threading.Lock()
        self._channels: dict[str, Any] = {}
        self._latest: dict[str, tuple[int, bytes]] = {}
        self._state_topics = set(rs.JSON_TOPICS) | {rs.MAP, rs.GRID, rs.PATHS, rs.IMAGE, rs.CALIBRATION, rs.DEPTH} - {rs.ROBOT_STATE}
        try:
            self.server = foxglove.start_server(name="MorphoNavi", host="127.0.0.1", port=port, context=self._ctx,
                                                server_listener=self)
        except RuntimeError as exc:  # FoxgloveError: the port is taken
            raise OSError(f"Foxglove live view on 127.0.0.1:{port}: {exc}") from None
        for topic in (*rs.FOXGLOVE_TYPES, *rs.JSON_TOPICS):  # every topic advertised from the start
            self._channel(topic)
        log.info("Foxglove live view on ws://127.0.0.1:%d", self.port)

    @property
    def port(self) -> int:
        return int(self.server.port)

    def _channel(self, topic: str) -> Any:
        ch = self._channels.get(topic)
        if ch is None:
            fg = self._fg
            if topic in rs.FOXGLOVE_TYPES:
                s = rs.FOXGLOVE_TYPES[topic].get_schema()
                schema = fg.Schema(name=s.name, encoding=s.encoding, data=bytes(s.data))
                ch = fg.Channel(topic, schema=schema, message_encoding="protobuf", context=self._ctx)
            else:
                schema = fg.Schema(name=rs.JSON_TOPICS[topic], encoding="jsonschema", data=b'{"type":"object"}')
                ch = fg.Channel(topic, schema=schema, message_encoding="json", context=self._ctx)
            self._channels[topic] = ch
        return ch

    def log(self, topic: str, ns: int, data: bytes) -> None:
        """Send one encoded message (log time ``ns`` [ns since the epoch]) to the subscribed clients."""
        with self._lock:
            ch = self._channel(topic)
            if topic in self._state_topics:
                self._latest[topic] = (ns, data)
        ch.log(data, log_time=ns)

    # --- foxglove.websocket.ServerListener ---------------------------------------------------------
    def on_subscribe(self, client: Any, channel: Any) -> None:
        with self._lock:
            latest = self._latest.get(channel.topic)
            ch = self._channels.get(channel.topic)
        if latest is not None and ch is not None:
            ch.log(latest[1], log_time=latest[0])  # the current map etc. at once (other subscribers get it again)

    def on_unsubscribe(self, client: Any, channel: Any) -> None:
        pass

    def on_client_advertise(self, client: Any, channel: Any) -> None:
        pass

    def on_client_unadvertise(self, client: Any, client_channel_id: int) -> None:
        pass

    def on_message_data(self, client: Any, client_channel_id: int, data: bytes) -> None:
        pass  # no client publishing: the live view is read-only

    def close(self) -> None:
        try:
            self.server.stop()
        except Exception:  # stopping twice or after a failed start
            log.debug("Foxglove live view: stop failed", exc_info=True)
