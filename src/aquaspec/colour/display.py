"""From linear camera RGB to a display image (NumPy float64 reference).

The renderer produces *linear camera RGB*: ``RGB_c = sum_i w_i L_i R_c(lambda_i)``
with the camera's own response curves (see SPEC "Spectral to RGB"), at
whatever absolute scale the radiance has. This module turns that into pixels a
person can look at, in a fixed order::

    check finite -> white balance (camera RGB) -> 3x3 matrix (camera -> linear
    sRGB) -> exposure (2**EV, manual or automatic) -> tone map -> sRGB
    encoding (IEC 61966-2-1) -> quantisation (uint8 or uint16)

White balance comes first because it is defined on the sensor's channels (as a
camera applies its multipliers to raw data) and a characterisation matrix is
fitted for white-balanced data. Exposure is a single scale factor, so it
commutes with both; automatic exposure is *measured* on the image that enters
the tone curve.

Every step is a plain function over arrays with a last axis of length 3, and
:func:`to_display` chains them and reports what it did. Choices are ``method=``
registries (:data:`WHITE_BALANCE_METHODS`, :data:`TONEMAPS`) whose keys are
the accepted names.

Luminance of camera RGB
-----------------------
Camera RGB is not a colorimetric space, so the Rec. 709 luminance weights
(0.2126, 0.7152, 0.0722) have no meaning for it. Automatic exposure uses the
plain mean of the three channels, ``Y = (R + G + B) / 3``, as its
"luminance-like" value (:func:`luminance_like`); it is proportional to
luminance for neutral colours in a white-balanced image, which is all that
exposure needs.

References
----------
.. [IEC61966] IEC 61966-2-1:1999, "Multimedia systems and equipment - Colour
   measurement and management - Part 2-1: Default RGB colour space - sRGB".
.. [Narkowicz2015] K. Narkowicz, "ACES Filmic Tone Mapping Curve", blog post,
   2016-01-06, https://knarkowicz.wordpress.com/2016/01/06/aces-filmic-tone-mapping-curve/
.. [Hable2010] J. Hable, "Filmic Tonemapping Operators" / "Uncharted 2: HDR
   Lighting", GDC 2010; http://filmicworlds.com/blog/filmic-tonemapping-operators/
.. [Reinhard2002] E. Reinhard, M. Stark, P. Shirley, J. Ferwerda,
   "Photographic tone reproduction for digital images", ACM TOG 21(3), 2002,
   Eqs. 1-3 (log-average luminance, key value 0.18, L / (1 + L)).
"""

from __future__ import annotations

import math
from numbers import Real

import numpy as np

from aquaspec.colour.srgb import srgb_encode
from aquaspec.errors import AquaspecError
from aquaspec.io.finite import check_finite

#: Accepted range of a manual exposure in EV (stops). 2**64 covers any
#: physical radiance scale; beyond it the caller has almost certainly passed
#: a scale factor instead of a number of stops.
EV_LIMIT = 64.0

#: Default mid-grey the automatic exposure maps the log-average to
#: ([Reinhard2002]'s "key" of a normal-key scene).
DEFAULT_KEY = 0.18

#: Default upper percentile of the luminance-like value kept by automatic
#: exposure: the brightest 2 % (the sun, Snell's window near the edge of the
#: frame, specular glints) do not vote.
DEFAULT_PERCENTILE = 98.0

#: Pixels darker than this fraction of the upper-percentile level are taken
#: at this level when averaging logarithms: a black pixel would otherwise
#: contribute log(0) = -inf. 1e-3 is about ten stops below the bright end,
#: the range a display can show.
_LOG_FLOOR = 1e-3


# ---------------------------------------------------------------------------
# input checks
# ---------------------------------------------------------------------------

def _as_rgb(rgb, what="image") -> np.ndarray:
    """float64 array with a last axis of 3 and only finite values."""
    try:
        arr = np.asarray(rgb, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise AquaspecError(f"{what} must be a numeric array of RGB values, got "
                            f"{type(rgb).__name__} ({exc})") from exc
    if arr.ndim < 1 or arr.shape[-1] != 3:
        raise AquaspecError(f"{what} has shape {arr.shape}; accepted: (..., 3), "
                            "e.g. (height, width, 3) linear RGB")
    check_finite(arr, what)
    return arr


def check_ev(ev) -> float:
    """An exposure in EV, checked: a finite number within the accepted range."""
    if isinstance(ev, bool) or not isinstance(ev, (Real, np.integer, np.floating)):
        raise AquaspecError(f"exposure {ev!r} is not accepted; give a number of stops "
                            f"(EV) in [-{EV_LIMIT:g}, {EV_LIMIT:g}] or 'auto'")
    ev = float(ev)
    if not math.isfinite(ev) or abs(ev) > EV_LIMIT:
        raise AquaspecError(f"exposure EV {ev!r} is out of range; accepted: a finite "
                            f"number in [-{EV_LIMIT:g}, {EV_LIMIT:g}] or 'auto'")
    return ev


def _lookup(registry: dict, name, what: str):
    if not isinstance(name, str) or name not in registry:
        raise AquaspecError(f"unknown {what} {name!r}; accepted: "
                            + ", ".join(repr(k) for k in registry))
    return registry[name]


# ---------------------------------------------------------------------------
# exposure
# ---------------------------------------------------------------------------

def luminance_like(rgb) -> np.ndarray:
    """Mean of the three channels, ``(R + G + B) / 3``, shape ``rgb.shape[:-1]``.

    Used instead of a colorimetric luminance because camera RGB has no defined
    luminance weights (see the module notes).
    """
    return np.asarray(rgb, dtype=np.float64).mean(axis=-1)


def exposure_ev(rgb, ev) -> np.ndarray:
    """Scale linear RGB by ``2**ev`` (``ev`` in stops, within +-:data:`EV_LIMIT`)."""
    ev = check_ev(ev)
    return _as_rgb(rgb) * 2.0 ** ev


def auto_exposure(rgb, key=DEFAULT_KEY, percentile=DEFAULT_PERCENTILE) -> float:
    """Exposure (EV) that maps the image's log-average level to ``key``.

    With ``Y`` the per-pixel :func:`luminance_like` value, ``Y_p`` its
    ``percentile``-th percentile and ``P`` the pixels with ``Y <= Y_p``::

        Y_avg = exp( mean_{P} log(max(Y, 1e-3 * Y_p)) )
        EV    = log2(key / Y_avg)

    so that ``exposure_ev(rgb, EV)`` has a geometric-mean level of ``key``
    over ``P`` (a constant image maps exactly to ``key``). The geometric mean
    ([Reinhard2002] Eq. 1) and the percentile cut keep a few very bright
    pixels, such as Snell's window seen from below or the sun's disc, from
    darkening the whole image; the floor keeps black pixels from pulling it
    to zero.

    Parameters
    ----------
    rgb : array_like, shape (..., 3)
        Linear RGB, non-negative (negative values count as 0), finite.
    key : float
        Target mid level in (0, 1]; 0.18 is a normal-key scene.
    percentile : float
        Upper percentile in (0, 100] of pixels that take part.

    Returns
    -------
    float
        EV in stops. An all-black image gives 0 (no exposure can help).
    """
    rgb = _as_rgb(rgb)
    if isinstance(key, bool) or not isinstance(key, Real) or not 0.0 < key <= 1.0:
        raise AquaspecError(f"auto-exposure key {key!r} is not accepted; accepted: "
                            "a number in (0, 1], 0.18 for a normal-key scene")
    if (isinstance(percentile, bool) or not isinstance(percentile, Real)
            or not 0.0 < percentile <= 100.0):
        raise AquaspecError(f"auto-exposure percentile {percentile!r} is not accepted; "
                            "accepted: a number in (0, 100]")
    y = np.maximum(luminance_like(rgb), 0.0).ravel()
    if y.size == 0:
        raise AquaspecError("auto exposure of an empty image; give at least one pixel")
    y_hi = float(np.percentile(y, percentile))
    if y_hi <= 0.0:
        return 0.0
    kept = y[y <= y_hi]
    log_avg = float(np.mean(np.log(np.maximum(kept, _LOG_FLOOR * y_hi))))
    return math.log2(key) - log_avg / math.log(2.0)


# ---------------------------------------------------------------------------
# white balance
# ---------------------------------------------------------------------------

def _gains_none(rgb, reference_rgb):
    return np.ones(3)


def _gains_grey_world(rgb, reference_rgb):
    # Grey world (Buchsbaum 1980): the scene averages to grey, so each
    # channel's mean is scaled to the mean of the three channel means, which
    # keeps the overall level (and hence the exposure) unchanged.
    means = np.maximum(rgb.reshape(-1, 3), 0.0).mean(axis=0)
    if np.any(means <= 0.0):
        raise AquaspecError(f"grey-world white balance: channel means {means.tolist()} "
                            "include zero, so that channel cannot be balanced; use "
                            "white_balance='none' or a 'white-patch' reference")
    return means.mean() / means


def _gains_white_patch(rgb, reference_rgb):
    # The underwater photographer's custom white balance: the camera RGB of a
    # grey card at the subject's depth is made neutral. Gains are normalised
    # to the reference's channel mean so its level stays the same.
    if reference_rgb is None:
        raise AquaspecError("white_balance='white-patch' needs reference_rgb=(R, G, B): "
                            "the camera RGB of a grey or white card in the scene")
    ref = np.asarray(reference_rgb, dtype=np.float64)
    if ref.shape != (3,) or not np.all(np.isfinite(ref)) or np.any(ref <= 0.0):
        raise AquaspecError(f"white-patch reference_rgb {reference_rgb!r} is not accepted; "
                            "accepted: three finite, positive camera RGB values "
                            "(a channel at 0 cannot be balanced)")
    return ref.mean() / ref


#: White-balance methods: name -> ``f(rgb, reference_rgb) -> (3,) gains``.
WHITE_BALANCE_METHODS = {
    "none": _gains_none,
    "grey-world": _gains_grey_world,
    "white-patch": _gains_white_patch,
}


def white_balance_gains(rgb, method="none", *, reference_rgb=None) -> np.ndarray:
    """Per-channel multipliers (3,) of a white-balance ``method``.

    Parameters
    ----------
    rgb : array_like, shape (..., 3)
        Linear camera RGB (used by ``"grey-world"``).
    method : str
        A key of :data:`WHITE_BALANCE_METHODS`: ``"none"`` (gains 1),
        ``"grey-world"`` (equal channel means), ``"white-patch"`` (the
        ``reference_rgb`` becomes neutral: gains ``mean(ref) / ref``).
    reference_rgb : array_like of 3 floats, optional
        Camera RGB of a neutral reference; only for ``"white-patch"``.
    """
    fn = _lookup(WHITE_BALANCE_METHODS, method, "white-balance method")
    if reference_rgb is not None and method != "white-patch":
        raise AquaspecError(f"reference_rgb is only used by white_balance='white-patch', "
                            f"not {method!r}; drop it or choose 'white-patch'")
    return fn(_as_rgb(rgb), reference_rgb)


def von_kries(reference_rgb, cone_matrix) -> np.ndarray:
    """Chromatic adaptation to a neutral reference, as a 3x3 matrix on RGB.

    The human eye's counterpart of a camera's white-patch gains (von Kries
    1902; CIECAM02's CAT02, CIE 159:2004): each cone response
    ``cone_matrix @ rgb`` is scaled so that the reference's becomes white's
    (``cone_matrix @ (1, 1, 1)``), and the result is scaled to the
    reference's channel mean. Unlike per-channel gains it accepts an RGB
    reference with a negative channel (a colour outside sRGB) as long as
    its cone responses are positive.
    """
    ref = np.asarray(reference_rgb, dtype=np.float64)
    cone = np.asarray(cone_matrix, dtype=np.float64)
    if ref.shape != (3,) or not np.all(np.isfinite(ref)):
        raise AquaspecError(f"white-patch reference_rgb {reference_rgb!r} is not accepted; "
                            "accepted: three finite RGB values")
    if cone.shape != (3, 3) or not np.all(np.isfinite(cone)):
        raise AquaspecError(f"cone matrix of shape {cone.shape} is not accepted; accepted: "
                            "a finite 3x3 matrix from RGB to cone responses")
    lms = cone @ ref
    if np.any(lms <= 0.0) or ref.mean() <= 0.0:
        raise AquaspecError(f"white-patch reference_rgb {reference_rgb!r} has cone "
                            f"responses {lms.tolist()}; accepted: a reference whose cone "
                            "responses and channel mean are positive")
    white = cone @ np.ones(3)
    return ref.mean() * np.linalg.solve(cone, (white / lms)[:, None] * cone)


def white_balance(rgb, method="none", *, reference_rgb=None) -> np.ndarray:
    """``rgb`` times :func:`white_balance_gains` (same shape, float64)."""
    rgb = _as_rgb(rgb)
    return rgb * white_balance_gains(rgb, method, reference_rgb=reference_rgb)


# ---------------------------------------------------------------------------
# camera RGB -> linear sRGB
# ---------------------------------------------------------------------------

def apply_matrix(rgb, matrix=None) -> np.ndarray:
    """Apply a 3x3 colour matrix ``M`` to every pixel: ``out = M @ rgb``.

    ``matrix=None`` is the identity: the camera's channels are shown as if
    they were sRGB primaries. That is *not* colorimetrically right (a raw
    sensor's RGB is not sRGB; a characterisation matrix fitted by least
    squares over known reflectances, as pbrt's ``PixelSensor`` does, would
    be), but it is what an uncorrected camera image looks like and it adds no
    assumption; a fitted matrix can be passed here once one exists.
    Negative results (colours outside the display gamut) are kept; the tone
    map clips them.
    """
    rgb = _as_rgb(rgb)
    if matrix is None:
        return rgb
    return rgb @ _check_matrix(matrix).T


def _check_matrix(matrix) -> np.ndarray:
    m = np.asarray(matrix, dtype=np.float64)
    if m.shape != (3, 3) or not np.all(np.isfinite(m)):
        raise AquaspecError(f"colour matrix of shape {m.shape} is not accepted; accepted: "
                            "a finite 3x3 matrix mapping camera RGB (columns) to "
                            "linear sRGB (rows), or None for the identity")
    return m


# ---------------------------------------------------------------------------
# tone mapping: non-negative linear -> [0, 1]
# ---------------------------------------------------------------------------

#: Both filmic curves are at 1 long before this; clamping their input here
#: keeps ``x * x`` from overflowing to inf / inf = NaN for huge finite values.
_SATURATED = 1e6


def _tonemap_none(x):
    return np.clip(x, 0.0, 1.0)


def _tonemap_aces_narkowicz(x):
    # [Narkowicz2015]: rational fit of the ACES RRT + sRGB ODT,
    # x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14). Monotonic for x >= 0
    # (the derivative's numerator has only positive coefficients) and
    # reaches 1 at x ~= 7.24, above which it is clamped.
    x = np.clip(x, 0.0, _SATURATED)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


_HABLE_A, _HABLE_B, _HABLE_C = 0.15, 0.50, 0.10   # shoulder, linear strength, linear angle
_HABLE_D, _HABLE_E, _HABLE_F = 0.20, 0.02, 0.30   # toe strength, toe numerator, denominator
_HABLE_WHITE = 11.2                               # linear white point
_HABLE_BIAS = 2.0                                 # exposure bias of the published shader


def _hable_partial(x):
    a, b, c, d, e, f = _HABLE_A, _HABLE_B, _HABLE_C, _HABLE_D, _HABLE_E, _HABLE_F
    return (x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f) - e / f


def _tonemap_hable(x):
    # [Hable2010]: the "Uncharted 2" curve with its published constants,
    # exposure bias 2 and white point 11.2; f(0) = 0 exactly.
    x = np.clip(x, 0.0, _SATURATED)
    return np.clip(_hable_partial(_HABLE_BIAS * x) / _hable_partial(_HABLE_WHITE), 0.0, 1.0)


def _tonemap_reinhard(x):
    # [Reinhard2002] Eq. 3, L / (1 + L) per channel: never reaches 1.
    x = np.maximum(x, 0.0)
    return x / (1.0 + x)


#: Tone maps: name -> ``f(x) -> [0, 1]``, applied per channel to exposed
#: linear values. ``"filmic"`` is the ACES fit of [Narkowicz2015].
TONEMAPS = {
    "none": _tonemap_none,
    "filmic": _tonemap_aces_narkowicz,
    "hable": _tonemap_hable,
    "reinhard": _tonemap_reinhard,
}


def tonemap(x, method="filmic") -> np.ndarray:
    """Tone map exposed linear values to [0, 1] per channel.

    ``method`` is a key of :data:`TONEMAPS`: ``"none"`` (clip to [0, 1]),
    ``"filmic"`` (ACES fit, [Narkowicz2015]), ``"hable"`` ([Hable2010]),
    ``"reinhard"`` (``x / (1 + x)``, [Reinhard2002]). Negative values become 0.
    """
    fn = _lookup(TONEMAPS, method, "tone map")
    x = np.asarray(x, dtype=np.float64)
    check_finite(x, "tone-map input")
    return fn(x)


# ---------------------------------------------------------------------------
# quantisation (the sRGB encoding before it: aquaspec.colour.srgb)
# ---------------------------------------------------------------------------

#: Accepted output bit depths -> integer dtype.
BIT_DEPTHS = {8: np.uint8, 16: np.uint16}


def quantize(encoded, bit_depth=8) -> np.ndarray:
    """Round [0, 1] values to the nearest code of ``bit_depth`` (8 or 16) bits."""
    if bit_depth not in BIT_DEPTHS or isinstance(bit_depth, bool):
        raise AquaspecError(f"bit depth {bit_depth!r} is not accepted; accepted: 8, 16")
    v = np.asarray(encoded, dtype=np.float64)
    check_finite(v, "encoded image")
    top = float(2 ** bit_depth - 1)
    return np.rint(np.clip(v, 0.0, 1.0) * top).astype(BIT_DEPTHS[bit_depth])


# ---------------------------------------------------------------------------
# the whole chain
# ---------------------------------------------------------------------------

def display_settings(rgb, *, exposure="auto", white_balance="none", reference_rgb=None,
                     matrix=None, key=DEFAULT_KEY, percentile=DEFAULT_PERCENTILE,
                     cone_matrix=None) -> dict:
    """Resolve the image-dependent settings of :func:`to_display`.

    Computes the white-balance gains and the exposure (automatic exposure is
    measured on the white-balanced, matrixed image, as :func:`to_display`
    applies them) without producing pixels, so that another implementation
    of the same chain (the GPU display pass) can use exactly these numbers.
    Arguments as in :func:`to_display`.

    Returns
    -------
    dict
        JSON-ready: ``exposure_mode``, ``exposure_ev``, ``exposure_scale``,
        ``white_balance``, ``white_balance_gains`` (3 floats),
        ``reference_rgb``, ``matrix`` (3x3 list or None: the matrix applied
        after the gains) and, for automatic exposure, ``auto_key`` and
        ``auto_percentile``. With ``cone_matrix`` and ``"white-patch"`` the
        balance is :func:`von_kries`: gains 1, ``adaptation_matrix`` the
        adaptation and ``matrix`` the colour matrix times it.
    """
    rgb = _as_rgb(rgb)
    auto = isinstance(exposure, str)
    if auto and exposure != "auto":
        raise AquaspecError(f"exposure {exposure!r} is not accepted; accepted: 'auto' "
                            f"or a number of stops (EV) in [-{EV_LIMIT:g}, {EV_LIMIT:g}]")
    manual_ev = None if auto else check_ev(exposure)
    rgb = np.maximum(rgb, 0.0)
    adaptation = None
    if cone_matrix is not None and white_balance == "white-patch":
        if reference_rgb is None:
            white_balance_gains(rgb, white_balance)       # its error names what is missing
        adaptation = von_kries(reference_rgb, cone_matrix)
        gains = np.ones(3)
        matrix = adaptation if matrix is None else _check_matrix(matrix) @ adaptation
    else:
        gains = white_balance_gains(rgb, white_balance, reference_rgb=reference_rgb)
    x = apply_matrix(rgb * gains, matrix)
    ev = auto_exposure(x, key, percentile) if auto else manual_ev
    settings = {
        "exposure_mode": "auto" if auto else "manual",
        "exposure_ev": float(ev),
        "exposure_scale": float(2.0 ** ev),
        "white_balance": white_balance,
        "white_balance_gains": [float(g) for g in gains],
        "reference_rgb": None if reference_rgb is None else [float(v) for v in reference_rgb],
        "matrix": None if matrix is None else np.asarray(matrix, float).tolist(),
    }
    if adaptation is not None:
        settings["white_balance_space"] = "cones (von Kries, CAT02)"
        settings["adaptation_matrix"] = adaptation.tolist()
    if auto:
        settings["auto_key"] = float(key)
        settings["auto_percentile"] = float(percentile)
    return settings


def to_display(rgb, *, exposure="auto", white_balance="none", reference_rgb=None,
               tonemap="filmic", matrix=None, key=DEFAULT_KEY,
               percentile=DEFAULT_PERCENTILE, bit_depth=8, cone_matrix=None):
    """Linear camera RGB (H, W, 3) to an sRGB-encoded integer image.

    Parameters
    ----------
    rgb : array_like, shape (H, W, 3)
        Linear camera RGB at any non-negative scale; every value must be
        finite (otherwise :class:`AquaspecError` says how many are not and
        where the first one is). Negative values are counted in the info and
        treated as 0.
    exposure : "auto" or float
        ``"auto"``: :func:`auto_exposure` with ``key`` and ``percentile``;
        a number: EV in stops (scale ``2**EV``).
    white_balance : str
        A key of :data:`WHITE_BALANCE_METHODS`.
    reference_rgb : 3 floats, optional
        Neutral reference for ``white_balance="white-patch"``.
    tonemap : str
        A key of :data:`TONEMAPS`.
    matrix : (3, 3) array_like, optional
        Camera RGB -> linear sRGB (see :func:`apply_matrix`); None = identity.
    key, percentile : float
        Automatic exposure settings.
    bit_depth : int
        8 (uint8) or 16 (uint16).
    cone_matrix : (3, 3) array_like, optional
        RGB -> cone responses where the RGB is colorimetric
        (:meth:`aquaspec.colour.sensors.Sensor.cone_matrix`): ``"white-patch"`` is
        then an eye's chromatic adaptation (:func:`von_kries`) instead of
        per-channel gains.

    Returns
    -------
    image : ndarray, shape (H, W, 3), uint8 or uint16
    info : dict
        What was done, JSON-ready: the :func:`display_settings` entries
        (``exposure_mode``, ``exposure_ev``, ``exposure_scale``,
        ``auto_key`` / ``auto_percentile`` (auto only), ``white_balance``,
        ``white_balance_gains``, ``reference_rgb``, ``matrix``) plus
        ``tonemap``, ``encoding``, ``bit_depth``, ``negative_values`` (count
        set to 0), ``saturated_fraction`` (fraction of channel values at the
        top code) and ``size`` ([width, height]).
    """
    rgb = _as_rgb(rgb)
    if rgb.ndim != 3:
        raise AquaspecError(f"image has shape {rgb.shape}; accepted: (height, width, 3)")
    _lookup(TONEMAPS, tonemap, "tone map")
    if bit_depth not in BIT_DEPTHS or isinstance(bit_depth, bool):
        raise AquaspecError(f"bit depth {bit_depth!r} is not accepted; accepted: 8, 16")
    info = display_settings(rgb, exposure=exposure, white_balance=white_balance,
                            reference_rgb=reference_rgb, matrix=matrix, key=key,
                            percentile=percentile, cone_matrix=cone_matrix)

    n_negative = int(np.count_nonzero(rgb < 0.0))
    x = apply_matrix(np.maximum(rgb, 0.0) * info["white_balance_gains"], info["matrix"])
    with np.errstate(over="ignore"):   # overflow is reported just below
        x = x * info["exposure_scale"]
    check_finite(x, f"image after exposure EV {info['exposure_ev']:g}")
    top = 2 ** bit_depth - 1
    image = quantize(srgb_encode(TONEMAPS[tonemap](x)), bit_depth)

    info.update({
        "tonemap": tonemap,
        "encoding": "sRGB (IEC 61966-2-1)",
        "bit_depth": int(bit_depth),
        "negative_values": n_negative,
        "saturated_fraction": float(np.count_nonzero(image == top) / image.size),
        "size": [int(image.shape[1]), int(image.shape[0])],
    })
    return image, info
