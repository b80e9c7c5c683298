"""Resampling of texel maps shared by the analysis scripts (truth_mix.py,
weight_error.py): a ground-truth map at its own resolution compared with a
reconstruction's atlas at another."""
import numpy as np


def resize(img, R):
    """Bilinear resample to R x R at texel centres, clamped at the border."""
    if img.ndim == 2:
        img = img[..., None]
    H, W = img.shape[:2]
    if H == R and W == R:
        return img
    ys = (np.arange(R) + 0.5) * H / R - 0.5
    xs = (np.arange(R) + 0.5) * W / R - 0.5
    y0 = np.clip(np.floor(ys).astype(int), 0, H - 1)
    x0 = np.clip(np.floor(xs).astype(int), 0, W - 1)
    y1, x1 = np.clip(y0 + 1, 0, H - 1), np.clip(x0 + 1, 0, W - 1)
    fy = np.clip(ys - y0, 0, 1)[:, None, None]
    fx = np.clip(xs - x0, 0, 1)[None, :, None]
    top = img[y0][:, x0] * (1 - fx) + img[y0][:, x1] * fx
    bottom = img[y1][:, x0] * (1 - fx) + img[y1][:, x1] * fx
    return top * (1 - fy) + bottom * fy
