"""The live server: a foxglove-sdk WebSocket server in the recorder's process, mirroring
what the recorder writes (same channels, schemas and message bytes), sim time on the app's
timeline, and the app's commands handed back to the bench through a pipe.

It runs in the recorder child (hil/record/process.py), so a client costs the bench's tick
path nothing: serving, encoding for the socket and a slow client's backlog are the child's
(foxglove-sdk drops a slow client's oldest messages and never blocks ``log()``).

What goes back to the bench (``steer_fd``, length-prefixed pickles, read by hil/live/steer.py):
``("publish", topic, bytes)`` for a message the app published on /hil/inject or /hil/steer,
``("playback", command, speed, seek_ns)`` for the app's play/pause/speed/seek controls,
``("server error", count, text)`` when messages could not be served (the first at once, then
at most once a second with the running count), so the run's events and summary say so.
"""

from __future__ import annotations

import os
import pickle
import threading
from typing import Any

import foxglove
from foxglove.websocket import (Capability, Client, ClientChannel, PlaybackCommand, PlaybackControlRequest,
                                PlaybackState, PlaybackStatus)

from hil import clock
from hil.live.topics import CLIENT_SCHEMAS, LEN, MIN_PERIOD_NS, LiveConfig, client_schema_bytes
from hil.record.topics import TOPICS, Encoding

NAME = "mav-hil-bench"


def _channel(ctx: foxglove.Context, topic: str) -> foxglove.Channel:
    """The served channel of a recorded topic: the MCAP file's schema bytes and encoding."""
    spec = TOPICS[topic]
    pb = spec.encoding is Encoding.PROTOBUF
    schema = foxglove.Schema(name=spec.schema_name, encoding="protobuf" if pb else "jsonschema",
                             data=spec.schema_bytes())
    return foxglove.Channel(topic, message_encoding=spec.encoding.value, schema=schema, context=ctx)


class _Listener(foxglove.websocket.ServerListener):
    """Runs on the server's threads: forwards the app's messages and controls to the bench."""

    def __init__(self, server: LiveServer) -> None:
        self._server = server
        self._client_topics: dict[tuple[int, int], str] = {}

    def on_client_advertise(self, client: Client, channel: ClientChannel) -> None:
        self._client_topics[(client.id, channel.id)] = channel.topic

    def on_client_unadvertise(self, client: Client, client_channel_id: int) -> None:
        self._client_topics.pop((client.id, client_channel_id), None)

    def on_message_data(self, client: Client, client_channel_id: int, data: bytes) -> None:
        topic = self._client_topics.get((client.id, client_channel_id), "")
        self._server.send(("publish", topic, bytes(data)))

    def on_playback_control_request(self, request: PlaybackControlRequest) -> PlaybackState | None:
        play = request.playback_command == PlaybackCommand.Play
        self._server.send(("playback", "play" if play else "pause", float(request.playback_speed), request.seek_time))
        status = PlaybackStatus.Playing if play else PlaybackStatus.Paused
        # the bench steps forward to a later time and refuses a seek back (hil/live/steer.py)
        seek = request.seek_time
        did_seek = seek is not None and int(seek) > self._server.last_log_time
        if did_seek:
            status = PlaybackStatus.Paused  # the run pauses where the seek ends
        return PlaybackState(status=status, current_time=self._server.last_log_time,
                             playback_speed=float(request.playback_speed), did_seek=did_seek,
                             request_id=request.request_id)


class LiveServer:
    """Start with :meth:`start` (returns the port), feed with :meth:`mirror` (the recorder's
    ``mirror`` hook), end with :meth:`close`."""

    def __init__(self, config: LiveConfig, *, run_start_unix_ns: int, end_unix_ns: int, steer_fd: int) -> None:
        self.config = config
        self.run_start_unix_ns = run_start_unix_ns
        self.end_unix_ns = end_unix_ns
        self.steer_fd = steer_fd
        self.last_log_time = run_start_unix_ns
        self._ctx = foxglove.Context()
        self._channels: dict[str, foxglove.Channel] = {}
        self._next_ns: dict[str, int] = {}
        self._limited = {t for t in config.topics if config.limited(t)}
        self._send_lock = threading.Lock()
        self._server: Any = None
        self._next_time_ns = 0
        self.errors = 0  #: messages the server failed to take (the recording has them)
        self._reported_errors = 0
        self._next_report_ns = 0  #: host monotonic ns of the next error report allowed
        #: between two reports of the running error count, ns (the first goes at once)
        self.report_period_ns = 1_000_000_000

    def start(self) -> int:
        for topic in self.config.topics:
            self._channels[topic] = _channel(self._ctx, topic)
        for topic in CLIENT_SCHEMAS:  # advertised so the app's publish panel knows the schema
            foxglove.Channel(topic, message_encoding="json", context=self._ctx,
                             schema=foxglove.Schema(name=str(CLIENT_SCHEMAS[topic]["title"]), encoding="jsonschema",
                                                    data=client_schema_bytes(topic)))
        self._server = foxglove.start_server(
            name=NAME, host=self.config.host, port=self.config.port, context=self._ctx,
            capabilities=[Capability.Time, Capability.ClientPublish, Capability.PlaybackControl],
            supported_encodings=["json"], server_listener=_Listener(self),
            playback_time_range=(self.run_start_unix_ns, self.end_unix_ns))
        return int(self._server.port)

    def mirror(self, topic: str, log_time: int, data: bytes) -> None:
        """One recorded message (its MCAP bytes); decimated on the default set, and the app's
        clock moved to its sim time (at most every ``MIN_PERIOD_NS``)."""
        channel = self._channels.get(topic)
        if channel is None:
            return
        try:
            self._serve(topic, channel, log_time, data)
        except Exception as exc:  # noqa: BLE001 - the live view must never cost the recording
            self.errors += 1
            self._report(f"{topic}: {type(exc).__name__}: {exc}")

    def _report(self, text: str) -> None:
        """Tell the bench (its events and summary), without flooding the pipe."""
        now_ns = clock.monotonic_ns()  # paces the reports only
        if self._reported_errors and now_ns < self._next_report_ns:
            return
        self._reported_errors, self._next_report_ns = self.errors, now_ns + self.report_period_ns
        self.send(("server error", self.errors, text))

    def _serve(self, topic: str, channel: foxglove.Channel, log_time: int, data: bytes) -> None:
        if topic in self._limited:
            if log_time < self._next_ns.get(topic, 0):
                return
            self._next_ns[topic] = log_time + MIN_PERIOD_NS
        if log_time >= self._next_time_ns:
            self._next_time_ns = log_time + MIN_PERIOD_NS
            self._server.broadcast_time(log_time)
        if log_time > self.last_log_time:
            self.last_log_time = log_time
        channel.log(data, log_time=log_time)

    def send(self, item: tuple[Any, ...]) -> None:
        body = pickle.dumps(item, protocol=pickle.HIGHEST_PROTOCOL)
        data = LEN.pack(len(body)) + body
        with self._send_lock:  # whole frames from several server threads
            try:
                view = memoryview(data)
                while view:
                    view = view[os.write(self.steer_fd, view):]
            except OSError:
                pass  # the bench is gone or ending: nothing to steer

    def close(self) -> None:
        if self._server is not None:
            self._server.stop()
            self._server = None


__all__ = ["LiveServer"]
