"""How far an image is from a reference image, accumulated over frames.

RMS and largest absolute difference are in the output's units (DN of the
8-bit or 16-bit frame). PSNR uses scikit-image's definition,
10·log10(range² / MSE), with the MSE pooled over every frame; it is infinite
for identical images, which the result reports as ``psnr_db = None`` with
``identical = True`` (JSON and CSV never carry inf or NaN). SSIM is
scikit-image's ``structural_similarity``, the mean over the frames it is
asked for (it costs about 0.4 s per 1080p gray frame); 1 for identical
frames without computing it.
"""

from __future__ import annotations

import math

import numpy as np

# The keys of :meth:`ImageError.result`.
IMAGE_FIELDS = ("rms_dn", "max_abs_dn", "psnr_db", "identical", "ssim", "rms_e")


def data_range_of(image: np.ndarray, adc_bits: int) -> float:
    """Range of an output frame's values: 255 for 8-bit frames, else the ADC's 2^bits − 1."""
    return 255.0 if image.dtype == np.uint8 else float(2**adc_bits - 1)


class ImageError:
    """Differences of images from their references, frame after frame.

    Parameters
    ----------
    data_range : float
        Range of the pixel values (PSNR, SSIM).
    """

    def __init__(self, data_range: float):
        self.data_range = float(data_range)
        self._squares = 0.0
        self._count = 0
        self._max_abs = 0.0
        self._ssim: list[float] = []
        self._electron_squares = 0.0
        self._electron_count = 0

    def add(self, reference: np.ndarray, image: np.ndarray, ssim: bool = False) -> None:
        """Add one frame; ``ssim`` also computes its structural similarity."""
        difference = image.astype(np.float64) - reference.astype(np.float64)
        self._squares += float(np.square(difference).sum())
        self._count += difference.size
        self._max_abs = max(self._max_abs, float(np.abs(difference).max(initial=0.0)))
        if ssim:
            self._ssim.append(self._structural_similarity(reference, image))

    def add_electrons(self, reference_e: np.ndarray, electrons: np.ndarray) -> None:
        """Add one frame's mean electrons before the ADC (finer than the output's DN)."""
        difference = np.asarray(electrons, dtype=np.float64) - np.asarray(reference_e, dtype=np.float64)
        self._electron_squares += float(np.square(difference).sum())
        self._electron_count += difference.size

    def _structural_similarity(self, reference: np.ndarray, image: np.ndarray) -> float:
        if np.array_equal(reference, image):
            return 1.0
        from skimage.metrics import structural_similarity

        channel_axis = -1 if image.ndim == 3 else None
        return float(structural_similarity(reference, image, data_range=self.data_range, channel_axis=channel_axis))

    def result(self) -> dict:
        """``rms_dn``, ``max_abs_dn``, ``psnr_db`` (None if identical), ``identical``,
        ``ssim`` (None if never computed), ``rms_e`` (None if never given)."""
        mse = self._squares / self._count if self._count else 0.0
        identical = self._max_abs == 0.0
        return {
            "rms_dn": math.sqrt(mse),
            "max_abs_dn": self._max_abs,
            "psnr_db": None if identical else 10.0 * math.log10(self.data_range**2 / mse),
            "identical": identical,
            "ssim": float(np.mean(self._ssim)) if self._ssim else None,
            "rms_e": math.sqrt(self._electron_squares / self._electron_count) if self._electron_count else None,
        }
