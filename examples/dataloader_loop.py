"""A PyTorch ``DataLoader`` loop over a split.

``synthcal.load_split`` returns a ``torch.utils.data.Dataset`` of
``(image (3, H, W) float32 in [0, 1], semantic (H, W) int64, H (3, 3) float64)``
items, held in memory (it pickles, so ``num_workers`` works). This script fits a
per-pixel colour classifier (a 1 × 1 convolution: RGB → 4 class logits) for a few
epochs on the train split and reports its pixel accuracy on the test split.

    python examples/dataloader_loop.py [OUT]    # OUT: where the store goes (default: a temporary folder)
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import torch
from torch.utils.data import DataLoader

import synthcal

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="synthcal-"))
store = synthcal.generate_store("intersection-1", out, profile="smoke")
train, test = synthcal.load_split(store, "train", seed=0), synthcal.load_split(store, "test", seed=0)

torch.manual_seed(0)
model = torch.nn.Conv2d(3, 4, kernel_size=1)
optimiser = torch.optim.Adam(model.parameters(), lr=0.05)
for epoch in range(5):
    total = 0.0
    for images, semantics, _ in DataLoader(train, batch_size=8, shuffle=True):
        loss = torch.nn.functional.cross_entropy(model(images), semantics)
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
        total += loss.item() * len(images)
    print(f"epoch {epoch}: cross-entropy {total / len(train):.3f}")

with torch.no_grad():
    correct = sum(int((model(images).argmax(1) == semantics).sum()) for images, semantics, _ in DataLoader(test, 8))
print(f"test pixel accuracy {correct / test.semantics.size:.1%} ({len(test)} images)")
