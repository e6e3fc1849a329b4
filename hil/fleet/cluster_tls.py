"""TLS credentials for a Dask cluster of campaign hosts (docs/replay-and-campaigns.md).

    python -m hil.fleet.cluster_tls DIR

writes into ``DIR`` (created; files already there are never overwritten):

* ``dask-cluster.pem``: a self-signed certificate, its own CA (valid 365 days);
* ``dask-cluster.key``: its private key (mode 0600);
* ``hil-tls.yaml``: Dask configuration requiring TLS for the scheduler, the workers and the
  client, with those two files as every role's credentials (absolute paths into ``DIR``).

Copy ``DIR`` to the same path on every host of the cluster and ``hil-tls.yaml`` into Dask's
configuration there (``/etc/dask/``, ``~/.config/dask/``, or the directory ``DASK_CONFIG``
names). The credentials are Dask's own (``distributed.security.Security.temporary()``, as the
local cluster of ``hil campaign`` uses, here written to files); every host and client
presents the same certificate and checks the peer's against it, so the key is what admits a
host or a client to the cluster: keep it only on the cluster's hosts.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

CERT_FILE, KEY_FILE, CONFIG_FILE = "dask-cluster.pem", "dask-cluster.key", "hil-tls.yaml"


def _write_new(path: Path, text: str, mode: int) -> None:
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, mode)
    with os.fdopen(fd, "w") as f:
        f.write(text)


def config_text(cert: Path, key: Path) -> str:
    """Dask configuration: TLS required, ``cert``/``key`` for every role, ``cert`` as the CA."""
    import yaml  # Dask's own dependency

    roles = {role: {"cert": str(cert), "key": str(key)} for role in ("scheduler", "worker", "client")}
    tls = {"ca-file": str(cert), **roles}
    return str(yaml.safe_dump({"distributed": {"comm": {"require-encryption": True, "tls": tls}}}, sort_keys=False))


def write_credentials(directory: Path) -> tuple[Path, Path, Path]:
    """Make the certificate, the key and the configuration in ``directory``; returns their paths.
    FileExistsError if any is there already."""
    from distributed.security import Security

    directory = directory.resolve()
    directory.mkdir(parents=True, exist_ok=True)
    cert, key, config = directory / CERT_FILE, directory / KEY_FILE, directory / CONFIG_FILE
    for path in (cert, key, config):
        if path.exists():
            raise FileExistsError(f"{path} exists: credentials are never overwritten (remove it first)")
    security = Security.temporary()
    _write_new(key, security.tls_scheduler_key, 0o600)
    _write_new(cert, security.tls_scheduler_cert, 0o644)
    _write_new(config, config_text(cert, key), 0o644)
    return cert, key, config


def main(argv: list[str] | None = None) -> int:
    """Exit status: 0 written; 2 wrong call or a file in the way."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1 or args[0].startswith("-"):
        print("usage: python -m hil.fleet.cluster_tls DIR", file=sys.stderr)
        return 2
    try:
        cert, key, config = write_credentials(Path(args[0]))
    except (FileExistsError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"certificate {cert}\nkey         {key} (mode 0600: keep it on the cluster's hosts)\n"
          f"config      {config} (into /etc/dask/ or ~/.config/dask/ on every host)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
