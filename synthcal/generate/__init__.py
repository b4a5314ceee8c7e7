"""Generation: cameras, their renders and the stores they fill (SPEC §3-§6).

* :mod:`.camera` — pan-tilt-zoom cameras over a ground plane and their homographies;
* :mod:`.grid` — the camera parameter grids (sizes in closed form) and sampling from them;
* :mod:`.render` — a camera's view of a bird's-eye scene;
* :mod:`.pipeline` — ``synthcal generate``: one dataset spec → one complete sharded store;
* :mod:`.preview` and :mod:`.resources` — what a run will cost, and whether it fits, before it starts;
* :mod:`.splits` — drawing the per-seed train / test / dictionary splits;
* :mod:`.images` — rendering the images an ``images: splits`` store's splits use;
* :mod:`.worldcup` — the World Cup 2014 broadcast cameras as given poses;
* :mod:`.frames` — ``synthcal import``: real annotated frames into a store.

Imports of synthcal only :mod:`synthcal.config`, :mod:`synthcal.scenes`,
:mod:`synthcal.store` and :mod:`synthcal.utils`; nothing is imported here, so that
``synthcal.generate.render`` stays cheap to import.
"""
