"""Experiment (fifteenth session): render the STN's training view of an estimate as the scorer reads it — an
estimate whose bottom-centre pixel sees no ground is flipped (SPEC's sign rule) before the cheirality-masked warp."""
import os

if os.environ.get("SYNTHCAL_FLIP_EXPERIMENT") == "1":
    import torch

    import synthcal.training.examples as examples

    original = examples.StnExamples.warp

    def warp(self, H):
        w, h = self.data.work_size
        pixel = torch.tensor([(w - 1) / 2, h - 1, 1.0], dtype=H.dtype, device=H.device)
        depth = (torch.linalg.inv(H) @ pixel)[..., 2]
        sign = torch.where(depth < 0, -1.0, 1.0).to(H.dtype)
        return original(self, H * sign[:, None, None])

    examples.StnExamples.warp = warp
