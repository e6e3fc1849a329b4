"""The command-line options of ``hil run --live``, ``hil devices --live`` (and the pytest plugin's ``--hil-live``):
parsing the address, the topic set, and the loud warning for a bind beyond loopback."""

from __future__ import annotations

import sys
from typing import Annotated

import typer

from hil.live.topics import LiveConfig, select_topics

#: ``--live`` without ``--live-addr``
LOOPBACK = "127.0.0.1:0"

LiveOpt = Annotated[bool, typer.Option(
    "--live", help="Serve the run to Foxglove as it flies, and take its pause/step/speed and /hil/inject "
                   "(docs/live.md); prints the URL. 127.0.0.1 on a free port unless --live-addr.")]
DevicesLiveOpt = Annotated[bool, typer.Option(
    "--live", help="Serve the devices to Foxglove in real time (pose, attitude, motors, events, timing) and take "
                   "/hil/inject faults; pause/step/speed are refused (realtime). Prints the URL; 127.0.0.1 on a "
                   "free port unless --live-addr (docs/live.md).")]
LiveAddrOpt = Annotated[str | None, typer.Option(
    "--live-addr", metavar="HOST:PORT", help="With --live: where the server listens. No authentication: a bind "
                                             "beyond loopback is said loudly (docs/live.md, Security).")]
LiveTopicsOpt = Annotated[str | None, typer.Option(
    "--live-topics", help="With --live: more topics to serve beside the default set (comma-separated), or 'all'.")]


class LiveOptionError(ValueError):
    """A bad --live/--live-topics value (the message names the option and why)."""


def parse_live(addr: str | None, topics: str | None, *, record: bool = True, live: bool = True) -> LiveConfig | None:
    """``--live``, ``--live-addr`` (None: loopback, a free port) and ``--live-topics`` as a
    :class:`LiveConfig` (None without --live)."""
    if not live:
        if topics or addr:
            raise LiveOptionError(f"{'--live-topics' if topics else '--live-addr'}: needs --live")
        return None
    addr = addr or LOOPBACK
    if not record:
        raise LiveOptionError("--live: serves what the run records; it cannot be used with --no-record")
    host, sep, port_text = addr.rpartition(":")
    if not sep:
        host, port_text = addr, "0"
    host = host.strip("[]") or "127.0.0.1"
    try:
        port = int(port_text)
        if not 0 <= port <= 65535:
            raise ValueError
    except ValueError:
        raise LiveOptionError(f"--live-addr: must be HOST:PORT with a port 0..65535 (got {addr!r})") from None
    try:
        selected = select_topics(topics)
    except ValueError as exc:
        raise LiveOptionError(str(exc)) from None
    return LiveConfig(host=host, port=port, topics=selected)


def announcer(config: LiveConfig) -> LiveConfig:
    """``config`` with an ``announce`` that prints the URL to stderr (and the warning for a
    bind beyond loopback)."""
    from dataclasses import replace

    def announce(url: str) -> None:
        if not config.loopback:
            print(f"WARNING: the live server listens on {config.host}, beyond this machine, WITHOUT "
                  "AUTHENTICATION: anyone who reaches it sees the flight and can pause it and inject "
                  "faults (docs/live.md, Security).", file=sys.stderr, flush=True)
        print(f"live: {url}  (Foxglove: Open connection -> Foxglove WebSocket -> paste this URL; "
              "layout docs/foxglove-live-layout.json)", file=sys.stderr, flush=True)

    return replace(config, announce=announce)


def live_config(live: bool, addr: str | None, topics: str | None, *, record: bool = True) -> LiveConfig | None:
    """For the CLI: the parsed options with the printing announcer; exit 2 with an error line
    on a bad value."""
    try:
        config = parse_live(addr, topics, record=record, live=live)
    except LiveOptionError as exc:
        print(f"error: {exc}", file=sys.stderr)
        raise typer.Exit(2) from None
    return None if config is None else announcer(config)


__all__ = ["DevicesLiveOpt", "LOOPBACK", "LiveAddrOpt", "LiveOptionError", "LiveOpt", "LiveTopicsOpt", "announcer", "live_config", "parse_live"]
