"""Pan-tilt-zoom cameras over a ground plane, and their homographies.

Convention (SPEC §2)
--------------------
* Bird's-eye frame: a ground point is the bird's-eye pixel ``(u, v)`` (column, row,
  pixel centres at integers). World axes ``x = u``, ``y = v``, ``z = x × y`` point
  *down* into the ground; the ground is ``z = 0``.
* A camera at height ``Z`` above ground point ``(X, Y)`` has its centre at
  ``C = (X, Y, -Z)``.
* Pan ``θ`` (degrees) turns the view from +u toward +v; tilt ``φ`` is 0 when
  horizontal and negative when looking down. The viewing direction is
  ``d = (cos φ cos θ, cos φ sin θ, -sin φ)``; image right is
  ``x_c = (-sin θ, cos θ, 0)``; image down is ``y_c = d × x_c``.
* ``R`` has rows ``x_c, y_c, z_c = d``; ``t = -R C``;
  ``K = [[f, 0, c_x], [0, f, c_y], [0, 0, 1]]`` with ``c = ((W-1)/2, (H-1)/2)``.
* The homography ``H = K [r1 r2 t]`` maps a bird's-eye pixel to an image pixel,
  ``x_img ~ H (u, v, 1)ᵀ``; the third output coordinate is the depth, positive in
  front of the camera.

Example
-------
>>> import numpy as np
>>> H = homography(pan_deg=np.array([0.0]), tilt_deg=np.array([-10.0]),
...                focal_px=np.array([200.0]), position=np.array([[650.0, 950.0, 80.0]]),
...                image_size=(256, 144))
>>> H.shape
(1, 3, 3)
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "rotation",
    "intrinsics",
    "homography",
    "decompose_homography",
    "orient_homography",
]


def rotation(pan_deg: np.ndarray, tilt_deg: np.ndarray) -> np.ndarray:
    """World-to-camera rotations of cameras without roll.

    Args:
        pan_deg: (N,) pan angles in degrees.
        tilt_deg: (N,) tilt angles in degrees.

    Returns:
        (N, 3, 3) rotations whose rows are the camera's right, down and viewing
        axes expressed in world coordinates.
    """
    pan = np.deg2rad(np.asarray(pan_deg, dtype=np.float64))
    tilt = np.deg2rad(np.asarray(tilt_deg, dtype=np.float64))
    zeros = np.zeros_like(pan)
    view = np.stack([np.cos(tilt) * np.cos(pan), np.cos(tilt) * np.sin(pan), -np.sin(tilt)], axis=-1)
    right = np.stack([-np.sin(pan), np.cos(pan), zeros], axis=-1)
    down = np.cross(view, right)
    return np.stack([right, down, view], axis=-2)


def intrinsics(focal_px: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """Pinhole intrinsics with the principal point at the image centre.

    Args:
        focal_px: (N,) focal lengths in pixels *of the output image*.
        image_size: ``(width, height)`` of the output image.

    Returns:
        (N, 3, 3) matrices ``K``.
    """
    focal = np.asarray(focal_px, dtype=np.float64)
    width, height = image_size
    K = np.zeros(focal.shape + (3, 3))
    K[..., 0, 0] = focal
    K[..., 1, 1] = focal
    K[..., 0, 2] = (width - 1) / 2.0
    K[..., 1, 2] = (height - 1) / 2.0
    K[..., 2, 2] = 1.0
    return K


def homography(
    pan_deg: np.ndarray,
    tilt_deg: np.ndarray,
    focal_px: np.ndarray,
    position: np.ndarray,
    image_size: tuple[int, int],
) -> np.ndarray:
    """Bird's-eye → image homographies of N cameras.

    Args:
        pan_deg: (N,) pan in degrees (any scene heading already added).
        tilt_deg: (N,) tilt in degrees.
        focal_px: (N,) focal lengths in pixels of the output image (already scaled
            from the reference width).
        position: (N, 3) grid values ``(X, Y, Z)`` in bird's-eye pixels; ``Z`` is
            the height above the ground.
        image_size: ``(width, height)`` of the output image.

    Returns:
        (N, 3, 3) float64 homographies ``H = K [r1 r2 t]`` with the depth sign kept.
    """
    position = np.asarray(position, dtype=np.float64)
    centre = position * np.array([1.0, 1.0, -1.0])
    R = rotation(pan_deg, tilt_deg)
    t = -np.einsum("nij,nj->ni", R, centre)
    Rt = np.concatenate([R[..., :, :2], t[..., :, None]], axis=-1)
    return intrinsics(focal_px, image_size) @ Rt


def orient_homography(homography: np.ndarray, image_size: tuple[int, int]) -> np.ndarray:
    """Fix the overall sign of homographies whose sign is unknown (SPEC §2).

    A homography normalised e.g. to ``H[2, 2] = 1`` may have lost the sign that
    makes its third output coordinate the depth. The sign is chosen so that the
    bottom-centre pixel ``((W-1)/2, H-1)`` sees the ground.

    Args:
        homography: (N, 3, 3) bird's-eye → image homographies.
        image_size: ``(width, height)`` of the image.

    Returns:
        (N, 3, 3) homographies, each multiplied by ±1.
    """
    H = np.asarray(homography, dtype=np.float64)
    width, height = image_size
    bottom_centre = np.array([(width - 1) / 2.0, height - 1.0, 1.0])
    with np.errstate(all="ignore"):
        ground = np.linalg.solve(H, np.broadcast_to(bottom_centre, H.shape[:-1])[..., None])[..., 0]
    sign = np.where(ground[..., 2] < 0, -1.0, 1.0)
    return H * sign[..., None, None]


def decompose_homography(
    homography: np.ndarray, image_size: tuple[int, int]
) -> dict[str, np.ndarray]:
    """Recover pan, tilt, focal and centre of roll-free cameras from ``H``.

    Inverse of :func:`homography` for cameras with the principal point at the image
    centre, square pixels and no roll. With ``K⁻¹H = s [r1 r2 t]``, the columns
    ``r1, r2`` have equal norm, which fixes the focal length; the rest follows.

    Args:
        homography: (N, 3, 3) bird's-eye → image homographies (any scale; the sign
            is fixed with :func:`orient_homography`).
        image_size: ``(width, height)`` of the image.

    Returns:
        dict of (N,) arrays ``pan_deg``, ``tilt_deg``, ``roll_deg`` (≈ 0 for a
        camera of this model), ``focal_px`` (output-image pixels) and ``x``,
        ``y``, ``z`` (centre, ``z`` the height above ground).
    """
    H = orient_homography(homography, image_size)
    width, height = image_size
    cx, cy = (width - 1) / 2.0, (height - 1) / 2.0
    # Remove the principal point: A = diag(1/f, 1/f, 1) · M with M = T⁻¹ H.
    M = H.copy()
    M[..., 0, :] -= cx * H[..., 2, :]
    M[..., 1, :] -= cy * H[..., 2, :]
    a1, a2 = M[..., :, 0], M[..., :, 1]
    # |r1| = |r2| and r1 ⟂ r2 give f² from the first two columns.
    num = a1[..., 0] * a2[..., 0] + a1[..., 1] * a2[..., 1]
    den = a1[..., 2] * a2[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        f_sq_orth = -num / den
        f_sq_norm = (a1[..., 0] ** 2 + a1[..., 1] ** 2 - a2[..., 0] ** 2 - a2[..., 1] ** 2) / (
            a2[..., 2] ** 2 - a1[..., 2] ** 2
        )
    # The orthogonality equation degenerates when a column has no depth part; use
    # whichever equation is better conditioned.
    use_orth = np.abs(den) > 1e-3 * np.abs(a2[..., 2] ** 2 - a1[..., 2] ** 2)
    focal = np.sqrt(np.abs(np.where(use_orth, f_sq_orth, f_sq_norm)))
    scale_inv = np.stack([1.0 / focal, 1.0 / focal, np.ones_like(focal)], axis=-1)
    B = M * scale_inv[..., :, None]
    s = 0.5 * (np.linalg.norm(B[..., :, 0], axis=-1) + np.linalg.norm(B[..., :, 1], axis=-1))
    B = B / s[..., None, None]
    r1, r2, t = B[..., :, 0], B[..., :, 1], B[..., :, 2]
    r3 = np.cross(r1, r2)
    R = np.stack([r1, r2, r3], axis=-1)
    centre = -np.einsum("nji,nj->ni", R, t)
    view = R[..., 2, :]
    right = R[..., 0, :]
    tilt = np.rad2deg(np.arcsin(np.clip(-view[..., 2], -1, 1)))
    pan = np.rad2deg(np.arctan2(view[..., 1], view[..., 0]))
    expected_right = np.stack([-np.sin(np.deg2rad(pan)), np.cos(np.deg2rad(pan)), np.zeros_like(pan)], -1)
    roll = np.rad2deg(np.arctan2(np.einsum("ni,ni->n", np.cross(expected_right, right), view),
                                 np.einsum("ni,ni->n", expected_right, right)))
    return {
        "pan_deg": pan,
        "tilt_deg": tilt,
        "roll_deg": roll,
        "focal_px": focal,
        "x": centre[..., 0],
        "y": centre[..., 1],
        "z": -centre[..., 2],
    }
