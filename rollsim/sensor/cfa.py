"""Colour filter array: which channel each pixel sees, and demosaicing.

Every stage before the noise is linear in light, so with a CFA each pixel
simply gets its own channel's electron rate; the noise and the ADC act on the
mosaic as on a monochrome sensor, and the output stage demosaics the 8-bit
mosaic with OpenCV (VNG accepts 8-bit images only, so every method works on
the same 8-bit input).

A pattern is named by its top-left 2×2 block, read row by row (``RGGB``: R at
(0, 0), G at (0, 1) and (1, 0), B at (1, 1)). OpenCV's classic Bayer codes
name the pattern one pixel further along the diagonal, so ``RGGB`` is
``COLOR_BayerBG2RGB``; the table below spells that out.
"""

from __future__ import annotations

import numpy as np


CFA_PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")
DEMOSAIC_METHODS = ("bilinear", "edge_aware", "vng")
_CHANNEL = {"R": 0, "G": 1, "B": 2}
_OPENCV_NAME = {"RGGB": "BG", "BGGR": "RG", "GRBG": "GB", "GBRG": "GR"}
_OPENCV_SUFFIX = {"bilinear": "", "edge_aware": "_EA", "vng": "_VNG"}


def cfa_channels(pattern: str, shape: tuple[int, int]) -> np.ndarray:
    """Channel index (0 R, 1 G, 2 B) of every pixel of a frame.

    Parameters
    ----------
    pattern : {"RGGB", "BGGR", "GRBG", "GBRG"}
    shape : (int, int)
        ``(height, width)``.

    Returns
    -------
    ndarray of uint8, shape ``shape``
    """
    if pattern not in CFA_PATTERNS:
        raise ValueError(f"unknown CFA pattern {pattern!r}; expected one of {list(CFA_PATTERNS)}")
    block = np.array([_CHANNEL[c] for c in pattern], dtype=np.uint8).reshape(2, 2)
    height, width = shape
    tiled = np.tile(block, ((height + 1) // 2, (width + 1) // 2))
    return np.ascontiguousarray(tiled[:height, :width])


def demosaic_code(pattern: str, method: str) -> int:
    """The ``cv2.cvtColor`` code that demosaics ``pattern`` to RGB with ``method``."""
    if pattern not in CFA_PATTERNS:
        raise ValueError(f"unknown CFA pattern {pattern!r}; expected one of {list(CFA_PATTERNS)}")
    if method not in DEMOSAIC_METHODS:
        raise ValueError(f"unknown demosaicing method {method!r}; expected one of {list(DEMOSAIC_METHODS)}")
    import cv2  # OpenCV only where a mosaic is demosaiced: loading a scene does not need it

    return getattr(cv2, f"COLOR_Bayer{_OPENCV_NAME[pattern]}2RGB{_OPENCV_SUFFIX[method]}")


def demosaic(mosaic: np.ndarray, pattern: str, method: str) -> np.ndarray:
    """RGB image of an 8-bit mosaic.

    Parameters
    ----------
    mosaic : ndarray of uint8, shape (H, W)
    pattern : str
        See :data:`CFA_PATTERNS`.
    method : {"bilinear", "edge_aware", "vng"}
        Bilinear interpolation, OpenCV's edge-aware interpolation, or
        variable number of gradients.

    Returns
    -------
    ndarray of uint8, shape (H, W, 3), RGB order
    """
    if mosaic.dtype != np.uint8:
        raise ValueError(f"demosaicing needs an 8-bit mosaic, got {mosaic.dtype}")
    import cv2

    return cv2.cvtColor(mosaic, demosaic_code(pattern, method))
