"""synthcal: synthetic PTZ-camera datasets and a harness for homography estimation."""
__version__ = "0.1.0"
