"""``python -m flightcode --config FILE``: boot the devices and run the 400 Hz loop.

``--check-config``: only validate the config and say so (flightcode/check.py); nothing starts.

Exit status:

* 0 - stopped by SIGTERM or SIGINT (motors were set to minimum first);
* 1 - an unexpected internal error (motors set to minimum if the ESC port was open);
* 2 - the config file is missing or invalid (message names file, key and reason);
* 3 - a device could not be opened or did not answer at boot (message names the device).

Everything goes to stderr as logfmt lines (see :mod:`flightcode.log`).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import traceback
from collections.abc import MutableMapping
from types import FrameType

import serial

from flightcode.config import ConfigError, FlightConfig, load
from flightcode.drivers import sbus
from flightcode.drivers.base import DeviceError, SerialLike
from flightcode.gc_policy import LoopCollector
from flightcode.log import Logger

EXIT_OK, EXIT_INTERNAL, EXIT_CONFIG, EXIT_DEVICE = 0, 1, 2, 3

#: The thread-pool settings of the BLAS libraries numpy and scipy may load (OpenBLAS, an
#: OpenMP build, MKL).
BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def single_threaded_blas(environ: MutableMapping[str, str]) -> None:
    """Ask for one BLAS thread unless the environment says otherwise (read once, when numpy
    loads: call this before). The loop's matrices are 5x5: worker threads would not speed it
    up, only add threads that wake up beside it. numpy and scipy each load an OpenBLAS that
    starts a worker per extra core, two threads more on a two-core computer."""
    for var in BLAS_THREAD_VARS:
        environ.setdefault(var, "1")


class Shutdown(Exception):
    """Raised from the signal handler so a blocking read ends at once."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _ignore_signals() -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _on_signal(signum: int, frame: FrameType | None) -> None:
    # A second signal while shutting down must not interrupt the motors-to-minimum write.
    _ignore_signals()
    raise Shutdown(signum)


def open_ports(cfg: FlightConfig) -> dict[str, SerialLike]:
    """Open every configured port with the timeouts the drivers expect (see docs/flightcode.md)."""
    p = cfg.ports
    specs: list[tuple[str, dict[str, object]]] = [
        ("imu", {"timeout": cfg.failsafe.imu_timeout_s}),
        # a non-blocking write: pyserial follows a blocking write with a select for room,
        # one system call more every sample for 24 bytes that always fit (a short write
        # is counted and the bridge re-entered: flightcode/drivers/buspirate_spi.py)
        ("adc", {"timeout": cfg.adc.read_timeout_s, "write_timeout": 0}),
        ("rc", {"timeout": 0} if cfg.rc.frontend == "capture"
         else {"timeout": 0, "parity": serial.PARITY_EVEN, "stopbits": serial.STOPBITS_TWO}),
        ("esc", {"timeout": 0, "write_timeout": 0}),
    ]
    if cfg.telemetry.enable:
        specs.append(("telemetry", {"timeout": 0, "write_timeout": 0}))
    ports: dict[str, SerialLike] = {}
    try:
        for name, options in specs:
            port = getattr(p, name)
            try:
                ports[name] = serial.Serial(port.path, port.baud, exclusive=True, **options)
            except (serial.SerialException, OSError, ValueError) as exc:
                raise DeviceError(name, f"cannot open {port.path} at {port.baud} bit/s: {exc}") from None
    except DeviceError:
        for opened in ports.values():
            opened.close()
        raise
    return ports


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m flightcode", description="Quad-rotor flight code (400 Hz loop).")
    parser.add_argument("--config", required=True, help="vehicle TOML file (see docs/flightcode.md)")
    parser.add_argument("--check-config", action="store_true",
                        help="only validate the config: one JSON verdict line on stdout, exit 0 or 2 (flightcode/check.py)")
    args = parser.parse_args(argv)
    if args.check_config:
        from flightcode.check import check_config

        return check_config(args.config)
    log = Logger()
    try:
        cfg = load(args.config)
    except ConfigError as exc:
        log.error("config.invalid", file=exc.file, key=exc.key, reason=exc.reason)
        print(f"flightcode: invalid config: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    log.level = cfg.log_level
    if cfg.rc.frontend == "sbus" and cfg.ports.rc.baud != sbus.BAUD:
        log.warning("config.sbus_baud", baud=cfg.ports.rc.baud, expected=sbus.BAUD)

    previous = {sig: signal.signal(sig, _on_signal) for sig in (signal.SIGTERM, signal.SIGINT)}
    ports: dict[str, SerialLike] = {}
    flight = None
    collector = LoopCollector()
    try:
        ports = open_ports(cfg)
        log.info("ports.open", **{name: getattr(cfg.ports, name).path for name in ports})
        # Imported here: numpy and scipy.linalg take about half a second to import; the
        # config and port errors above should not wait for them.
        from flightcode.loop import FlightLoop, make_devices

        flight = FlightLoop(cfg, make_devices(cfg, ports, log), log)
        # collections between samples from now on (flightcode/gc_policy.py); the full
        # collection and freeze run before the IMU streams, not over its first samples
        flight.boot(before_measurement=collector.start)
        flight.run(between=collector.after_iteration)
        return EXIT_OK  # run() returns only with max_iterations
    except Shutdown as exc:
        log.info("signal", name=str(exc))
        if flight is not None:
            flight.shutdown()
        return EXIT_OK
    except DeviceError as exc:
        _ignore_signals()
        log.error("boot.failed", device=exc.device, reason=exc.reason)
        print(f"flightcode: device '{exc.device}' failed at boot: {exc.reason}", file=sys.stderr)
        if flight is not None:
            flight.shutdown()
        return EXIT_DEVICE
    except Exception as exc:  # last resort: motors safe, say what happened, non-zero status
        _ignore_signals()
        log.error("internal_error", error=repr(exc), traceback=traceback.format_exc())
        if flight is not None:
            try:
                flight.shutdown()
            except Exception:  # noqa: BLE001 - the port may be the thing that failed
                pass
        return EXIT_INTERNAL
    finally:
        _ignore_signals()
        if collector.running:
            collector.stop()
            log.info("gc", **{f"gen{g}_collections": n for g, n in sorted(collector.collections.items())})
        for port in ports.values():
            try:
                port.close()
            except OSError:
                pass
        for sig, handler in previous.items():  # matters when main() is called in-process
            signal.signal(sig, handler)


if __name__ == "__main__":
    single_threaded_blas(os.environ)  # this process only: main() may run inside a test
    sys.exit(main())
