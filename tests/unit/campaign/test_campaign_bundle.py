"""A campaign case as bytes: what travels to a worker, how it is written there, what comes
back, and the Dask TLS credentials for a cluster of such workers."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import yaml

from hil.config import ConfigError
from hil.config.rig import load_rig
from hil.fleet.campaign_bundle import land_result, materialize, pack_result, rig_files, scenario_files
from hil.fleet.campaign_file import load_campaign
from hil.fleet.campaign_worker import stop_mirror
from hil.fleet.cluster_tls import write_credentials

ROOT = Path(__file__).resolve().parents[3]
DATA = Path(__file__).with_name("data")
TEMPLATE = ROOT / "rigs" / "flightcode-paper-quad.toml"


def _rig(directory: Path, flight: str) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    rig = directory / "r.toml"
    rig.write_text(f'[rig]\nname = "r"\n\n[flight]\n{flight}\n')
    return rig


def _load_materialized(files: dict[str, tuple[int, bytes]], rig_rel: str, root: Path):  # noqa: ANN202
    materialize(files, root)
    return load_rig(root / rig_rel)


def test_the_default_rig_travels_with_its_template(tmp_path: Path) -> None:
    files, rig_rel = rig_files(ROOT / "rigs" / "paper-quad.toml", {}, tmp_path)
    assert rig_rel == "config/paper-quad.toml"
    assert set(files) == {"config/paper-quad.toml", "config/flightcode-paper-quad.toml"}
    assert files[rig_rel][1] == (ROOT / "rigs" / "paper-quad.toml").read_bytes()  # unchanged: the log attaches it
    rig = _load_materialized(files, rig_rel, tmp_path / "w")
    assert rig.flight_config_path == (tmp_path / "w" / "config" / "flightcode-paper-quad.toml").resolve()


def test_a_template_above_the_rig_keeps_its_relative_place(tmp_path: Path) -> None:
    """tests/unit/campaign/data/killer-rig.toml names ../../../../rigs/flightcode-paper-quad.toml."""
    files, rig_rel = rig_files(DATA / "killer-rig.toml", {}, tmp_path)
    assert set(files) == {"config/tests/unit/campaign/data/killer-rig.toml", "config/rigs/flightcode-paper-quad.toml"}
    assert files[rig_rel][1] == (DATA / "killer-rig.toml").read_bytes()
    rig = _load_materialized(files, rig_rel, tmp_path / "w")
    assert rig.flight_config_path.read_bytes() == TEMPLATE.read_bytes()
    assert rig.flight_config_path.is_relative_to((tmp_path / "w").resolve())


def test_an_absolute_template_is_rewritten_to_the_shipped_copy(tmp_path: Path) -> None:
    rig_path = _rig(tmp_path / "rigs", f'config = "{TEMPLATE}"')
    files, rig_rel = rig_files(rig_path, {}, tmp_path)
    rig = _load_materialized(files, rig_rel, tmp_path / "w")
    assert rig.flight_config_path.is_relative_to((tmp_path / "w").resolve())
    assert rig.flight_config_path.read_bytes() == TEMPLATE.read_bytes()


def test_a_swept_template_is_the_one_that_travels(tmp_path: Path) -> None:
    rig_path = _rig(tmp_path / "rigs", 'config = "a.toml"')
    (tmp_path / "rigs" / "a.toml").write_bytes(TEMPLATE.read_bytes())
    (tmp_path / "rigs" / "b.toml").write_text("# b\n")
    files, _ = rig_files(rig_path, {"flight.config": "b.toml"}, tmp_path)
    assert set(files) == {"config/r.toml", "config/b.toml"}
    with pytest.raises(ConfigError, match=r"r.toml: \[flight\] config: .*c.toml does not exist"):
        rig_files(rig_path, {"flight.config": "c.toml"}, tmp_path)


def test_files_the_command_names_travel_with_their_modes(tmp_path: Path) -> None:
    cwd = tmp_path / "project"
    (cwd / "build").mkdir(parents=True)
    (cwd / "build" / "fc").write_bytes(b"\x7fELF-ish")
    (cwd / "build" / "fc").chmod(0o755)
    (cwd / "run.sh").write_text("exec ./build/fc \"$@\"\n")
    (cwd / "run.sh").chmod(0o644)
    (tmp_path / "outside").write_text("x")
    command = ('command = ["bash", "run.sh", "./build/fc", "--config", "{config}", "/bin/true", "../outside", '
               '"no-such-file"]')
    rig_path = _rig(tmp_path / "rigs", f'config = "{TEMPLATE}"\n{command}')
    files, _ = rig_files(rig_path, {}, cwd)
    shipped = {k: v for k, v in files.items() if k.startswith("work/")}
    assert shipped == {"work/run.sh": (0o644, b'exec ./build/fc "$@"\n'), "work/build/fc": (0o755, b"\x7fELF-ish")}
    materialize(files, tmp_path / "w")
    assert os.access(tmp_path / "w" / "work" / "build" / "fc", os.X_OK)
    assert not os.access(tmp_path / "w" / "work" / "run.sh", os.X_OK)


@pytest.mark.parametrize("rel", ["../escape", "/etc/passwd", "a/../../b", ""])
def test_a_shipped_path_may_not_leave_the_case_directory(tmp_path: Path, rel: str) -> None:
    with pytest.raises(ValueError, match="unsafe path"):
        materialize({rel: (0o644, b"x")}, tmp_path / "w")
    assert not (tmp_path / "escape").exists()


def test_every_case_carries_what_its_loaders_read(tmp_path: Path) -> None:
    campaign = load_campaign(DATA / "two-seeds.toml")
    cases = campaign.cases(tmp_path / "run", cwd=tmp_path)
    assert [c["log_name"] for c in cases] == ["0000_hover-2s_s1.mcap", "0001_hover-2s_s2.mcap"]
    for case in cases:
        assert set(case["files"]) == {"config/paper-quad.toml", "config/flightcode-paper-quad.toml",
                                      "scenario/hover-2s.toml"}
        assert case["files"][case["scenario"]][1] == (DATA / "hover-2s.toml").read_bytes()
        assert not any(str(ROOT) in str(v) for k, v in case.items() if k not in ("files", "stop_file")), case
    assert scenario_files(DATA / "hover-2s.toml")[1] == "scenario/hover-2s.toml"


def test_the_kept_log_and_a_failed_case_come_back_to_the_client(tmp_path: Path) -> None:
    worker = tmp_path / "worker"
    (worker / "logs").mkdir(parents=True)
    (worker / "case").mkdir()
    (worker / "logs" / "0003_hover_s4.mcap.part").write_bytes(b"MCAP bytes")
    (worker / "case" / "output.txt").write_text("boom\n")
    packed = pack_result({"case_id": "0003", "passed": False, "log": str(worker / "logs" / "0003_hover_s4.mcap.part"),
                          "case_dir": str(worker / "case")})
    assert packed["log"] is None and "case_dir" not in packed and str(worker) not in repr(
        {k: v for k, v in packed.items() if k not in ("log_file", "case_files")})
    client = tmp_path / "campaign"
    client.mkdir()
    landed = land_result(packed, client)
    assert landed["log"] == str(client / "logs" / "0003_hover_s4.mcap.part")
    assert Path(landed["log"]).read_bytes() == b"MCAP bytes"
    assert (Path(landed["case_dir"]) / "output.txt").read_text() == "boom\n"
    assert "log_file" not in landed and "case_files" not in landed
    with pytest.raises(FileExistsError):  # never over another case's log
        land_result(packed, client)


def test_a_result_without_files_lands_unchanged(tmp_path: Path) -> None:
    result = {"case_id": "0000", "passed": True, "log": None}
    assert land_result(pack_result(result), tmp_path) == result
    assert list(tmp_path.iterdir()) == []


def test_the_stop_event_becomes_the_case_stop_file(tmp_path: Path) -> None:
    """A worker that cannot see the campaign's STOP file learns of a stop through a Dask event."""
    from distributed import Client, Event

    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        already = tmp_path / "already"
        Event("hil-test-stop-early", client=client).set()
        with stop_mirror("hil-test-stop-early", already):
            assert already.exists()  # set before the case: it must not start
        later = tmp_path / "later"
        event = Event("hil-test-stop-later", client=client)
        touched = threading.Event()
        with stop_mirror("hil-test-stop-later", later):
            assert not later.exists()
            event.set()
            for _ in range(200):  # the mirror asks every 0.5 s
                if later.exists():
                    touched.set()
                    break
                touched.wait(0.05)
        assert touched.is_set()
        quiet = tmp_path / "quiet"
        with stop_mirror("hil-test-stop-never", quiet):
            pass
        assert not quiet.exists()
    with stop_mirror(None, tmp_path / "none"):
        pass
    assert not (tmp_path / "none").exists()


def test_cluster_credentials(tmp_path: Path) -> None:
    cert, key, config = write_credentials(tmp_path / "tls")
    assert (key.stat().st_mode & 0o777) == 0o600
    first_key = key.read_text()
    assert cert.read_text().startswith("-----BEGIN CERTIFICATE-----")
    tls = yaml.safe_load(config.read_text())["distributed"]["comm"]
    assert tls["require-encryption"] is True
    assert tls["tls"] == {"ca-file": str(cert), **{r: {"cert": str(cert), "key": str(key)}
                                                   for r in ("scheduler", "worker", "client")}}
    again = subprocess.run([sys.executable, "-m", "hil.fleet.cluster_tls", str(tmp_path / "tls")],
                           capture_output=True, text=True, timeout=120)
    assert again.returncode == 2 and "credentials are never overwritten" in again.stderr
    assert key.read_text() == first_key
    wrong = subprocess.run([sys.executable, "-m", "hil.fleet.cluster_tls"], capture_output=True, text=True, timeout=120)
    assert wrong.returncode == 2 and wrong.stderr.startswith("usage:")
