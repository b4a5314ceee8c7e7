"""The torch warp against the generator's renderer, and gradients through it."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import torch

from synthcal.generate.camera import homography
from synthcal.generate.render import render_semantic
from synthcal.models.losses import dice_loss, mse_loss, one_hot_maps, top_dice_loss, top_mse_loss
from synthcal.models.stn import IDENTITY_H8, compose_homography
from synthcal.models.warp import cheirality_mask, warp_semantic

IMAGE = (64, 36)  # (width, height)



def synthetic_scene() -> np.ndarray:
    """200 × 300 bird's-eye class map: roads (1), terrain (2), bicycle paths (3)."""
    scene = np.zeros((200, 300), np.uint8)
    cv2.rectangle(scene, (10, 30), (290, 60), 1, -1)
    cv2.rectangle(scene, (130, 0), (160, 199), 1, -1)
    cv2.circle(scene, (70, 140), 40, 2, -1)
    cv2.rectangle(scene, (200, 100), (280, 180), 2, -1)
    cv2.rectangle(scene, (10, 68), (290, 76), 3, -1)
    cv2.circle(scene, (230, 40), 12, 3, -1)
    cv2.ellipse(scene, (220, 140), (30, 15), 30, 0, 360, 3, -1)
    return scene


# pan, tilt, focal (px at width 64), X, Y, Z
CAMERAS = np.array([
    [-90.0, -20.0, 40.0, 150.0, 250.0, 40.0],   # centre outside the scene, looking in
    [0.0, 0.0, 30.0, 150.0, 100.0, 30.0],       # tilt 0: horizon across the middle
    [0.0, -40.0, 50.0, 250.0, 130.0, 50.0],     # looking past the scene's right edge
    [33.3, -37.7, 52.1, 123.4, 87.6, 61.2],     # nothing integer
    [180.0, -5.0, 25.0, 290.0, 20.0, 15.0],     # nearly horizontal, past the left edge
    [-135.0, -60.0, 20.0, 200.0, 160.0, 120.0],
    [75.0, 0.0, 45.0, 100.0, 90.0, 10.0],       # tilt 0, low, ground behind it too
])


def camera_homographies(size: tuple[int, int] = IMAGE) -> np.ndarray:
    c = CAMERAS
    return homography(c[:, 0], c[:, 1], c[:, 2] * size[0] / 64, c[:, 3:], size)


def test_cameras_exercise_horizon_and_edges():
    """The set would catch a missing cheirality mask and a wrong border."""
    scene = synthetic_scene()
    Hs = camera_homographies()
    unmasked_differs = [
        (cv2.warpPerspective(scene, H, IMAGE, flags=cv2.INTER_NEAREST) != render_semantic(scene, H, IMAGE)).any()
        for H in Hs
    ]
    assert sum(unmasked_differs) >= 2
    assert all(render_semantic(scene, H, IMAGE).any() for H in Hs)


@pytest.mark.parametrize("size", [IMAGE, (256, 144), (63, 35)])
def test_nearest_reproduces_renderer_exactly(size):
    scene = synthetic_scene()
    Hs = camera_homographies(size)
    expected = np.stack([render_semantic(scene, H, size) for H in Hs])
    ids = warp_semantic(torch.from_numpy(scene), torch.from_numpy(Hs), size, "nearest")
    assert ids.dtype == torch.uint8 and ids.shape == (len(Hs), size[1], size[0])
    np.testing.assert_array_equal(ids.numpy(), expected)
    onehot = warp_semantic(one_hot_maps(torch.from_numpy(scene)), torch.from_numpy(Hs), size, "nearest")
    # Zero (not class 0) where nothing is seen, one-hot elsewhere.
    seen = onehot.sum(1) > 0
    np.testing.assert_array_equal(torch.where(seen, onehot.argmax(1), 0).numpy(), expected)
    assert (seen <= cheirality_mask(torch.from_numpy(Hs), size)).all()


def test_nearest_random_cameras_exact():
    rng = np.random.default_rng(0)
    n = 64
    Hs = homography(rng.uniform(-180, 180, n), rng.uniform(-45, 0, n), rng.uniform(15, 80, n),
                    np.stack([rng.uniform(-50, 350, n), rng.uniform(-50, 250, n), rng.uniform(5, 100, n)], 1), IMAGE)
    scene = synthetic_scene()
    expected = np.stack([render_semantic(scene, H, IMAGE) for H in Hs])
    got = warp_semantic(torch.from_numpy(scene), torch.from_numpy(Hs), IMAGE, "nearest").numpy()
    np.testing.assert_array_equal(got, expected)
    # OpenCV's own nearest warp (float32 positions since 4.11) agrees but for a few boundary pixels.
    opencv = np.stack([cv2.warpPerspective(scene, H, IMAGE, flags=cv2.INTER_NEAREST) for H in Hs])
    opencv[~cheirality_mask(torch.from_numpy(Hs), IMAGE).numpy()] = 0
    assert (opencv != expected).mean() < 2e-3


def test_single_and_per_view_scenes():
    scene = one_hot_maps(torch.from_numpy(synthetic_scene()), 4, torch.float64)
    Hs = torch.from_numpy(camera_homographies())
    shared = warp_semantic(scene, Hs, IMAGE, "bilinear")
    per_view = warp_semantic(scene.expand(len(Hs), -1, -1, -1), Hs, IMAGE, "bilinear")
    torch.testing.assert_close(shared, per_view)
    torch.testing.assert_close(warp_semantic(scene, Hs[2], IMAGE, "bilinear"), shared[2])
    nearest = warp_semantic(scene, Hs, IMAGE, "nearest")
    # Away from class boundaries, bilinear equals nearest.
    assert (shared.argmax(1) == nearest.argmax(1)).double().mean() > 0.9
    assert ((shared.sum(1) > 0) <= cheirality_mask(Hs, IMAGE)).all()


# --- gradients ---------------------------------------------------------------------

def _pair(camera: int = 3) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """(scene one-hot, true H (1, 3, 3), target one-hot view)."""
    scene_ids = synthetic_scene()
    H = camera_homographies()[camera:camera + 1]
    target = one_hot_maps(torch.from_numpy(render_semantic(scene_ids, H[0], IMAGE))[None])
    return one_hot_maps(torch.from_numpy(scene_ids)), torch.from_numpy(H), target


@pytest.mark.parametrize("loss", [mse_loss, dice_loss, top_mse_loss, top_dice_loss], ids=lambda f: f.__name__)
def test_gradient_reaches_h_bar(loss):
    scene, H, target = _pair()
    h_bar = (torch.tensor(IDENTITY_H8) + torch.tensor([0.02, 0, 0.05, 0, 0.03, -0.04, 0, 0]))[None]
    h_bar.requires_grad_(True)
    warped = warp_semantic(scene, compose_homography(h_bar, H, IMAGE), IMAGE, "bilinear")
    loss(warped, target).backward()
    assert torch.isfinite(h_bar.grad).all()
    assert h_bar.grad.abs().sum() > 0


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    scores = [np.logical_and(a == c, b == c).sum() / np.logical_or(a == c, b == c).sum()
              for c in (1, 2, 3) if ((a == c) | (b == c)).any()]
    return float(np.mean(scores))


@pytest.mark.parametrize("loss", [top_mse_loss, dice_loss], ids=lambda f: f.__name__)
def test_optimising_h_bar_recovers_the_view(loss):
    scene, H, target = _pair()
    scene_ids = synthetic_scene()
    truth = render_semantic(scene_ids, H[0].numpy(), IMAGE)
    start = torch.tensor(IDENTITY_H8) + torch.tensor([0.04, 0.02, 0.12, -0.03, 0.05, -0.10, 0.0, 0.0])
    h_bar = torch.nn.Parameter(start[None].clone())
    optimiser = torch.optim.Adam([h_bar], lr=0.005)

    def evaluate() -> tuple[float, float]:
        with torch.no_grad():
            estimate = compose_homography(h_bar, H, IMAGE)
            value = float(loss(warp_semantic(scene, estimate, IMAGE, "bilinear"), target))
            view = render_semantic(scene_ids, estimate[0].numpy(), IMAGE)
        return value, _iou(view, truth)

    loss_before, iou_before = evaluate()
    for _ in range(60):
        optimiser.zero_grad()
        value = loss(warp_semantic(scene, compose_homography(h_bar, H, IMAGE), IMAGE, "bilinear"), target)
        value.backward()
        optimiser.step()
    loss_after, iou_after = evaluate()
    assert loss_after < 0.7 * loss_before
    assert iou_after > iou_before + 0.1


# --- an independent implementation of the same warp -------------------------------

def test_bilinear_is_kornias_warp_perspective_with_the_mask():
    """The bilinear warp is kornia's warp_perspective times the cheirality mask, values
    and dH, in float64. kornia takes H as source (bird's-eye) → destination (image)
    pixels and inverts it, dsize as (h, w); zero padding. Its normalisation follows its
    own align_corners, so either value gives the same pixel mapping."""
    from kornia.geometry.transform import warp_perspective

    rng = np.random.default_rng(1)
    n = 24
    Hs = torch.from_numpy(homography(
        rng.uniform(-180, 180, n), rng.uniform(-45, 0, n), rng.uniform(15, 80, n),
        np.stack([rng.uniform(-50, 350, n), rng.uniform(-50, 250, n), rng.uniform(5, 100, n)], 1), IMAGE))
    mask = cheirality_mask(Hs, IMAGE)
    assert 0.3 < mask.double().mean() < 0.99  # horizons in view: the mask matters
    # A soft map, so that every sampling position has a gradient.
    scene = torch.rand(3, 200, 300, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
    weights = torch.rand(n, 3, IMAGE[1], IMAGE[0], generator=torch.Generator().manual_seed(1), dtype=torch.float64)

    def run(warp) -> tuple[torch.Tensor, torch.Tensor]:
        H = Hs.clone().requires_grad_(True)
        out = warp(H)
        (out * weights).sum().backward()
        return out.detach(), H.grad

    ours, ours_grad = run(lambda H: warp_semantic(scene, H, IMAGE, "bilinear"))
    theirs, theirs_grad = run(lambda H: warp_perspective(scene.expand(n, -1, -1, -1), H, (IMAGE[1], IMAGE[0]),
                                                          mode="bilinear", padding_mode="zeros", align_corners=True)
                              * cheirality_mask(H, IMAGE)[:, None])
    assert ours.abs().sum() > 0 and ours_grad.abs().sum() > 0
    torch.testing.assert_close(ours, theirs, rtol=0, atol=1e-10)
    torch.testing.assert_close(ours_grad, theirs_grad, rtol=1e-7, atol=1e-9 * float(ours_grad.abs().max()))
