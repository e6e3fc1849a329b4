"""A board run's firmware image: which ELF it flies (firmware/'s ARM build, made first when
it is out of date, or a file the rig names) and the flight config it flies with.

The firmware's ARM build has no file system: its flight config is compiled in
(``fw_flight_config_text``, ``fw_flight_config_text_len``; firmware/Makefile). A run flies the
config the rig and the scenario make, as a process run does: the rig's template with the
rig's ``[flight.overrides]`` and the scenario's ``[flight]`` tables laid over it
(:func:`flight_config_text`), written over the compiled-in text in the image's flash before
reset (:func:`install_config`). The firmware itself checks it at boot, as its host build
checks its file; the design inputs its generated headers were made from cannot change at run
time (it refuses the run, naming the key).
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

import tomli_w

from hil.board.core import Core
from hil.board.elf import FirmwareImage
from hil.config import ConfigError, load_toml
from hil.config.rig import Rig
from hil.config.scenario import Scenario
from hil.flight.firmware_build import FIRMWARE_DIR, FirmwareBuildError, build_firmware
from hil.flight.run_files import deep_merge

CONFIG_SYMBOL = "fw_flight_config_text"


def firmware_tree() -> Path:
    """The firmware/ tree ``firmware = "arm"`` builds: the one in the working directory (where
    hil runs; a mutant's copy under ``hil mutate``), else the bench's own."""
    here = Path.cwd() / "firmware"
    return here if (here / "Makefile").is_file() else FIRMWARE_DIR


def firmware_elf(rig: Rig) -> Path:
    """The ELF the rig's board flies: the ARM build of :func:`firmware_tree` (``make arm`` first,
    a no-op when it is up to date, its design headers and compiled-in config from the rig's
    ``[flight] config``), or the rig's file. :class:`ConfigError` when the build fails."""
    if not rig.flight.firmware_target:
        return rig.firmware_path
    tree = firmware_tree()
    try:
        build_firmware("arm", firmware_dir=tree,  # the bench's interpreter runs the design step (a copy has no .venv)
                       make_vars={"FLIGHT_CONFIG": str(rig.flight_config_path), "PYTHON": sys.executable})
    except FirmwareBuildError as exc:
        raise ConfigError(f"{rig.path}: [flight] firmware = \"arm\": the build failed: {exc}") from None
    return tree / "build" / "arm" / "fc.elf"


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def flight_config_text(rig: Rig, scenario: Scenario) -> bytes:
    """The run's flight config as TOML: the rig's template, its overrides, the scenario's."""
    config = load_toml(rig.flight_config_path)
    config = deep_merge(config, rig.flight.overrides)
    config = deep_merge(config, scenario.flight)
    return tomli_w.dumps(config).encode()


def install_config(core: Core, image: FirmwareImage, text: bytes, *, where: str) -> None:
    """Write ``text`` over the image's compiled-in flight config (flash, before reset).
    ``where`` names the config in errors. An image without the config's symbols flies its own
    (and may not be given one)."""
    length_symbol = f"{CONFIG_SYMBOL}_len"
    if CONFIG_SYMBOL not in image.symbols or length_symbol not in image.symbols:
        raise ConfigError(f"{where}: the firmware {image.path} has no compiled-in flight config "
                          f"({CONFIG_SYMBOL}) for the bench to set")
    at, length_at = image.symbol(CONFIG_SYMBOL), image.symbol(length_symbol)
    room = int.from_bytes(core.read_memory(length_at, 4), "little")  # the build's text, NUL after it
    if len(text) > room:
        raise ConfigError(f"{where}: the run's flight config is {len(text)} bytes; the firmware {image.path} "
                          f"holds {room} (its build's config file, comments included): rebuild it from a "
                          "longer config")
    core.uc.mem_write(at, text + b"\0")
    core.uc.mem_write(length_at, len(text).to_bytes(4, "little"))
