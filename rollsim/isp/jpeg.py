"""JPEG compression of a frame, as a phone's still or video pipeline leaves it.

The frame is encoded as a baseline JPEG (libjpeg's, 4:2:0 chroma for
colour) and decoded, so its blocking and ringing are the real codec's. A
grey frame's round trip is computed by :mod:`rollsim.isp.jpeg_islow`:
libjpeg's integer transforms and quantisation without the lossless entropy
coding between them, OpenCV's bits at a third of the time; a colour frame
goes through OpenCV's encoder and decoder. Both are deterministic: the same
frame and quality give the same bytes.

Known answer (what the tests check): the encoder's quantisation tables are
the IJG-scaled tables of ITU-T T.81 Annex K. A block of 8×8 equal pixels has
only a DC coefficient, 8·(v − 128), quantised with the step q_DC of the
luminance table's (0, 0) entry, 16, scaled for the quality; its decoded
pixels are off by at most q_DC/16 plus the rounding.
"""

from __future__ import annotations

import numpy as np

from rollsim.isp.jpeg_islow import quantisation_table, round_trip_grey


def jpeg_dc_step(quality: int) -> int:
    """The DC quantisation step of the luminance table at ``quality`` (IJG scaling).

    Parameters
    ----------
    quality : int
        1 … 100.
    """
    return int(quantisation_table(quality)[0, 0])


def jpeg_round_trip(image: np.ndarray, quality: int) -> np.ndarray:
    """``image`` encoded as a JPEG at ``quality`` and decoded again.

    Parameters
    ----------
    image : ndarray of uint8, shape (H, W) (grey) or (H, W, 3) (RGB)
    quality : int
        1 … 100, as OpenCV's ``IMWRITE_JPEG_QUALITY``.

    Returns
    -------
    ndarray of uint8, the shape of ``image``
    """
    jpeg_dc_step(quality)  # validates the range
    if image.ndim != 3:
        return round_trip_grey(np.ascontiguousarray(image), quality)  # refuses what is not uint8 (H, W)
    import cv2

    # OpenCV's codec takes BGR; rollsim's rgb8 frames are RGB.
    ok, encoded = cv2.imencode(".jpg", cv2.cvtColor(image, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("OpenCV could not encode the frame as JPEG")
    decoded = cv2.imdecode(encoded, cv2.IMREAD_COLOR)
    if decoded is None:
        raise RuntimeError("OpenCV could not decode the JPEG it encoded")
    return cv2.cvtColor(decoded, cv2.COLOR_BGR2RGB)
