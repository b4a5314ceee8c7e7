"""synthcal: synthetic PTZ-camera datasets and a harness for homography estimation.

The Python API (README, "Python API")::

    import synthcal
    store = synthcal.generate_store("intersection-1", "work/data", profile="smoke")   # OUT/NAME.zarr, splits drawn
    train, test = synthcal.load_split(store, "train"), synthcal.load_split(store, "test")
    estimates = my_estimator.predict(test.images)        # (K, 3, 3) bird's-eye pixel → image pixel
    synthcal.evaluate(test, estimates)["iou_weighted"]

Every name of ``__all__`` is imported on first use (PEP 562), so ``import synthcal``
loads neither torch, OpenCV, pandas nor zarr. ``EXPORTS`` says where each lives.
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

try:
    # The version lives in one place, pyproject.toml; the installed metadata carries it.
    __version__ = version("synthcal")
except PackageNotFoundError:  # imported from a source tree that was never installed
    __version__ = "unknown"

# Public name → "module:attribute", imported when first asked for. The one place that
# says where the public names live: the TYPE_CHECKING block below mirrors it for mypy,
# tests/test_api.py checks that the two agree and that every name resolves.
EXPORTS: dict[str, str] = {
    "load_config": "synthcal.api:load_config",
    "generate_store": "synthcal.api:generate_store",
    "open_store": "synthcal.api:open_store",
    "load_split": "synthcal.api:load_split",
    "SplitDataset": "synthcal.data.loaders:SplitDataset",
    "Estimator": "synthcal.estimators.protocol:Estimator",
    "evaluate": "synthcal.api:evaluate",
    "evaluate_images": "synthcal.api:evaluate_images",
    "bench": "synthcal.api:bench",
    "segmentation_quality": "synthcal.api:segmentation_quality",
    "report": "synthcal.api:report",
    "paired_differences": "synthcal.api:paired_differences",
    "paired_contrast": "synthcal.api:paired_contrast",
}

# Written out (not derived from EXPORTS) so that linters and IDEs read it; tests/test_api.py holds the two equal.
__all__ = ["__version__", "load_config", "generate_store", "open_store", "load_split", "SplitDataset", "Estimator",
           "evaluate", "evaluate_images", "bench", "segmentation_quality", "report", "paired_differences",
           "paired_contrast"]

if TYPE_CHECKING:
    from synthcal.api import (
        bench,
        evaluate,
        evaluate_images,
        generate_store,
        load_config,
        load_split,
        open_store,
        paired_contrast,
        paired_differences,
        report,
        segmentation_quality,
    )
    from synthcal.data.loaders import SplitDataset
    from synthcal.estimators.protocol import Estimator


def __getattr__(name: str) -> Any:
    """Import a public name on first use and keep it in the module (PEP 562)."""
    target = EXPORTS.get(name)
    if target is None:
        raise AttributeError(f"module 'synthcal' has no attribute {name!r}")
    module, _, attribute = target.partition(":")
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(EXPORTS))
