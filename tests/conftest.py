"""Fixtures shared by the test modules: the bundled configuration and smoke stores.

Generating a store is the slow part of many tests, and several modules need the
same ones (the five intersections at smoke size). They are generated once per
session, on first request, into one folder under the session's temporary
directory. Modules never use these pristine stores directly: each takes copies
(:meth:`SmokeStores.copy`) and draws its own splits into them, so a test that
writes into a store (splits, resume, damage) cannot change what another sees.
"""

from __future__ import annotations

import io
import os
import shutil
import signal
import sys
from collections.abc import Iterable
from pathlib import Path

import pytest

from synthcal.config import LoadedConfig, load_config
from synthcal.eval.harness import run_threads
from synthcal.generate.pipeline import generate_dataset
from synthcal.utils.dispatch import thread_environment

ROOT = Path(__file__).resolve().parents[1]


def pytest_configure(config: pytest.Config) -> None:
    """Let Ctrl-C reach the code under test even when the suite was started with SIGINT ignored.

    A shell ignores SIGINT in the jobs it starts in the background (``make test &``,
    ``nohup``), and an ignored signal stays ignored across ``exec``: Python then never
    raises KeyboardInterrupt, here or in the subprocesses the Ctrl-C tests start, and
    those tests would fail for a reason that is not in synthcal. A handler (not SIG_IGN)
    is reset to the default on ``exec``, so the subprocesses get Python's own as well.
    """
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    share_cores_among_workers()


def share_cores_among_workers() -> None:
    """Give each pytest-xdist worker its share of the cores for torch's threads (and its subprocesses').

    torch starts a thread per core in every process; two workers on two cores then run four
    threads that spin against each other, and the suite is slower than one process (measured:
    192 s with two workers, 166 s in one, 117 s with two workers of one thread each). The same
    rule as ``bench --workers`` (:func:`~synthcal.eval.harness.run_threads`). Set in the environment
    before any test imports torch, so that the subprocesses the tests start inherit it; a value
    the user set is kept.
    """
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if "PYTEST_XDIST_WORKER" not in os.environ or workers < 2:
        return
    for name, value in thread_environment(run_threads(workers)).items():
        os.environ.setdefault(name, value)


class SmokeStores:
    """Pristine smoke stores of the bundled configuration, generated on first request.

    Every store is generated with one worker (``tests/generate/test_pipeline.py`` compares
    other worker counts against it) and never written to afterwards.
    """

    def __init__(self, config: LoadedConfig, root: Path) -> None:
        self.config = config
        self.root = root

    def path(self, name: str) -> Path:
        """``ROOT/NAME.zarr``, generated now if this session has not made it yet. Read only."""
        store = self.root / f"{name}.zarr"
        if not store.exists():
            generate_dataset(self.config.resolve(name, "smoke"), self.root, workers=1, progress=False)
        return store

    def copy(self, names: Iterable[str], out: Path) -> dict[str, Path]:
        """Copies of the named stores side by side in ``out`` (where mixed dictionaries look for their sources).

        Returns:
            dataset name → path of its copy, ``out/NAME.zarr``.
        """
        out.mkdir(parents=True, exist_ok=True)
        return {name: Path(shutil.copytree(self.path(name), out / f"{name}.zarr")) for name in names}


@pytest.fixture(scope="session")
def smoke_config() -> LoadedConfig:
    """The bundled ``datasets.yaml``."""
    return load_config(ROOT / "datasets.yaml")


@pytest.fixture(scope="session")
def smoke_stores(smoke_config: LoadedConfig, tmp_path_factory: pytest.TempPathFactory) -> SmokeStores:
    """The session's pristine smoke stores; take copies with ``smoke_stores.copy(names, folder)``."""
    return SmokeStores(smoke_config, tmp_path_factory.mktemp("smoke-stores"))


class FakeTerminal(io.StringIO):
    """Standard input typed at a terminal."""

    def isatty(self) -> bool:
        return True


@pytest.fixture
def terminal(monkeypatch, capsys):
    """Standard input and error on a terminal; returns a function that types the answer (the CLI's questions
    are asked only there)."""
    def answer(text: str) -> None:
        monkeypatch.setattr(sys.stderr, "isatty", lambda: True)  # the test's own (captured) standard error
        monkeypatch.setattr(sys, "stdin", FakeTerminal(text + "\n"))
    return answer
