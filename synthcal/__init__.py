"""synthcal: synthetic PTZ-camera datasets and a harness for homography estimation."""

from importlib.metadata import PackageNotFoundError, version

try:
    # The version lives in one place, pyproject.toml; the installed metadata carries it.
    __version__ = version("synthcal")
except PackageNotFoundError:  # imported from a source tree that was never installed
    __version__ = "unknown"
