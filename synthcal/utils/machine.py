"""What a run's floats depend on beyond its code and settings: the machine and its libraries.

A bundled model trained twice with the same code, settings, data and cached stages
is bit-identical at one thread count on one machine, not at another thread count: the
threads split torch's sums differently, the last bits of a training step differ, and
after some epochs so can the epoch validation keeps (measured: docs/reproduction.md,
intersection-2, "The cell again"; benchmarks/run_threads.py). Another processor may
round differently too: PyTorch picks its CPU kernels by the instruction set it finds
(``torch.backends.cpu.get_cpu_capability``: ``AVX2``, ``AVX512``, …). A run records
:func:`machine_record` so that two runs that differ can be told apart by their
machines rather than by guessing.
"""

from __future__ import annotations

import platform
import sys
from pathlib import Path

__all__ = ["machine_record", "cpu_model"]


def cpu_model(cpuinfo: Path = Path("/proc/cpuinfo")) -> str:
    """The processor's model name (Linux: ``/proc/cpuinfo``'s ``model name``), else :func:`platform.processor`.

    >>> isinstance(cpu_model(), str)
    True
    """
    try:
        for line in cpuinfo.read_text(encoding="utf-8", errors="replace").splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and value.strip():
                return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def machine_record() -> dict[str, str | int]:
    """The machine and library versions that decide a trained model's last bits, as JSON-ready values.

    Keys: ``cpu`` (:func:`cpu_model`), ``python``, ``numpy``, and, when this process
    has imported torch (a NumPy estimator's run never does: its process starts
    faster without it), ``torch``, ``cpu_capability`` (the instruction set PyTorch's
    CPU kernels use) and ``torch_threads`` (``torch.get_num_threads()`` here).
    """
    import numpy as np

    record: dict[str, str | int] = {"cpu": cpu_model(), "python": platform.python_version(),
                                    "numpy": str(np.__version__)}
    torch = sys.modules.get("torch")
    if torch is not None:
        record.update(torch=str(torch.__version__), cpu_capability=str(torch.backends.cpu.get_cpu_capability()),
                      torch_threads=int(torch.get_num_threads()))
    return record
