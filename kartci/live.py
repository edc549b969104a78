"""`kartci run --live`: the running scenario served to Foxglove over its WebSocket protocol
(foxglove-sdk), on 127.0.0.1 only, paced to real time so a person can watch it. Every message
the run publishes is sent as it is logged (CDR, with its ros2msg schema); what is published once
(the track, the URDF, /tf_static) is sent again to each client that subscribes later."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from kartci.errors import SpecError
from kartci.logs.qos import offered_qos_profiles
from kartci.logs.types import typestore
from kartci.sim.session import LIVE_TAPS

HOST = "127.0.0.1"  # never another interface: a debugging aid, not a service


class LiveView:
    """A Foxglove WebSocket server fed by a Session tap."""

    def __init__(self, port: int, rate: float = 1.0) -> None:
        """Start the server on HOST:`port` (0: any free port); `rate` is sim seconds per wall
        second (0: as fast as the simulator goes)."""
        try:
            import foxglove  # optional dependency: foxglove-sdk (kartci[live])
        except ImportError as err:
            raise SpecError("kartci run --live needs foxglove-sdk: pip install "
                            '"kartci[live]"') from err
        self._fox = foxglove
        self.context = foxglove.Context()
        self.rate = rate
        self.channels: dict[str, Any] = {}
        self.latched: dict[int, tuple[Any, bytes, int]] = {}  # channel id -> (channel, data, t)
        self._t0: float | None = None
        try:
            self.server = foxglove.start_server(
                name="kartci", host=HOST, port=port, context=self.context,
                capabilities=[foxglove.Capability.Time], server_listener=_Resend(self))
        except Exception as err:  # the port is taken, or not ours to bind
            raise SpecError(f"--live: cannot serve on {HOST}:{port} ({err})") from None

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return int(self.server.port)

    def _channel(self, topic: str, typename: str, latched: bool) -> Any:
        ch = self.channels.get(topic)
        if ch is None:
            text, _ = typestore().generate_msgdef(typename, ros_version=2)
            schema = self._fox.Schema(name=typename, encoding="ros2msg", data=text.encode())
            ch = self._fox.Channel(topic, schema=schema, message_encoding="cdr",
                                   context=self.context,
                                   metadata={"offered_qos_profiles":
                                             offered_qos_profiles(latched)})
            self.channels[topic] = ch
        return ch

    def __call__(self, topic: str, message: Any, t_ns: int, latched: bool) -> None:
        """Send one message (a Session tap), after waiting for its moment at `rate`."""
        typename = message.__msgtype__
        data = bytes(typestore().serialize_cdr(message, typename))
        ch = self._channel(topic, typename, latched)
        if latched:
            self.latched[ch.id()] = (ch, data, t_ns)
        if t_ns == 0 and latched:
            self._t0 = time.monotonic()  # a new run starts
        self._pace(t_ns)
        ch.log(data, log_time=t_ns)
        self.server.broadcast_time(t_ns)

    def _pace(self, t_ns: int) -> None:
        if self.rate <= 0 or self._t0 is None:
            return
        ahead = t_ns * 1e-9 / self.rate - (time.monotonic() - self._t0)
        if ahead > 0.002:
            time.sleep(ahead)

    def resend(self, channel_id: int) -> None:
        """A client subscribed: give it the channel's latched message, if it has one."""
        item = self.latched.get(channel_id)
        if item is not None:
            ch, data, t_ns = item
            ch.log(data, log_time=t_ns)

    def close(self) -> None:
        """Stop the server."""
        self.server.stop()


class _Resend:
    """foxglove ServerListener: latched messages for late subscribers."""

    def __init__(self, view: LiveView) -> None:
        self.view = view

    def on_subscribe(self, client: Any, channel: Any) -> None:
        self.view.resend(int(channel.id))

    def __getattr__(self, name: str) -> Any:  # the listener's other callbacks: nothing to do
        if name.startswith("on_"):
            return lambda *args, **kwargs: None
        raise AttributeError(name)


@contextmanager
def serving(port: int, rate: float = 1.0) -> Iterator[LiveView]:
    """Every Session started inside the block is served live on HOST:`port`."""
    view = LiveView(port, rate)
    token = LIVE_TAPS.set((view,))
    try:
        yield view
    finally:
        LIVE_TAPS.reset(token)
        view.close()
