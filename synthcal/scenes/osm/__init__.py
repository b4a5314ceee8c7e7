"""Intersection scenes from OpenStreetMap (SPEC §4): the public names of :mod:`.build`.

The work is split by stage: :mod:`.read` (pyosmium reader, the scene frame),
:mod:`.classes` (tags → classes), :mod:`.paint` (semantic and material maps),
:mod:`.dress` (RGB), :mod:`.build` (the cached entry point, store attributes);
:mod:`.junctions` is the catalogue of an extract's road junctions (``synthcal osm-junctions``).
"""

from __future__ import annotations

from .build import OSM_ATTRIBUTION, OSM_LICENCE, build_osm_scene, cache_folder, file_sha256, osm_attributes

__all__ = ["build_osm_scene", "osm_attributes", "file_sha256", "OSM_LICENCE", "OSM_ATTRIBUTION", "cache_folder"]
