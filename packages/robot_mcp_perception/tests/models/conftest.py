"""Model adapters against the real libraries (ultralytics, transformers, torch on the CPU),
with random-weight checkpoints built at test time by the libraries' own builders.

The libraries come from ``scripts/install-model-libs.sh`` (run by ``make setup``). Where they
are absent the tests skip saying so — except in CI (``CI`` set), where their absence fails.
Nothing may leave the machine: :func:`no_network` fails any non-loopback connect or lookup.
"""

from __future__ import annotations

import contextlib
import importlib.util
import ipaddress
import os
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

LIBRARIES = ("torch", "torchvision", "ultralytics", "transformers", "timm")
MISSING = [name for name in LIBRARIES if importlib.util.find_spec(name) is None]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    if not MISSING or os.environ.get("CI"):
        return
    skip = pytest.mark.skip(
        reason=f"{', '.join(MISSING)} not installed: run scripts/install-model-libs.sh"
    )
    for item in items:
        if "tests/models/" in str(item.path):
            item.add_marker(skip)


def _loopback(host: Any) -> bool:
    if host in ("localhost", None, ""):
        return True
    try:
        return ipaddress.ip_address(str(host).split("%")[0]).is_loopback
    except ValueError:
        return False


@contextlib.contextmanager
def network_disabled() -> Iterator[list[str]]:
    """Any attempt to reach beyond loopback (connect or name lookup) fails and is recorded."""
    attempts: list[str] = []
    real_connect = socket.socket.connect
    real_getaddrinfo = socket.getaddrinfo

    def connect(self: socket.socket, address: Any) -> Any:
        host = address[0] if isinstance(address, tuple) else address
        if self.family in (socket.AF_INET, socket.AF_INET6) and not _loopback(host):
            attempts.append(f"connect {address!r}")
            raise OSError(f"network disabled in this test: connect to {address!r}")
        return real_connect(self, address)

    def getaddrinfo(host: Any, *args: Any, **kwargs: Any) -> Any:
        if not _loopback(host):
            attempts.append(f"lookup {host!r}")
            raise socket.gaierror(f"network disabled in this test: lookup of {host!r}")
        return real_getaddrinfo(host, *args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(socket.socket, "connect", connect)
        patch.setattr(socket, "getaddrinfo", getaddrinfo)
        yield attempts


@pytest.fixture
def no_network() -> Iterator[list[str]]:
    with network_disabled() as attempts:
        yield attempts


@pytest.fixture(scope="session")
def checkpoints(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("random-weights")
