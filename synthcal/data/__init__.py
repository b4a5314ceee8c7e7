"""Loading splits of generated stores as PyTorch datasets, and the package's data files.

Data files (read with ``importlib.resources``): ``wc14/`` — the World Cup 2014 pitch
model and real camera annotations (SCCvSD, BSD 2-Clause, licence beside them);
``paper_iou.csv`` — every IoU figure of the reference paper's three result tables.
"""

from synthcal.data.loaders import SplitDataset, StoreScene, load_split, load_splits, read_scene
from synthcal.data.pool import LazyRows, load_pool_dictionary

__all__ = ["StoreScene", "SplitDataset", "LazyRows", "load_split", "load_splits", "load_pool_dictionary",
           "read_scene"]
