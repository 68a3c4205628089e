"""A made-up five-band medium shared by the NumPy shading tests
(test_shading.py, test_layers.py): water, light, a camera without negative
lobes, sigmoid band centres and two materials (grey, a ramp)."""

import numpy as np

N = 5
A = np.array([0.02, 0.03, 0.06, 0.25, 0.45])
B = np.array([0.06, 0.05, 0.045, 0.04, 0.035])
KD = np.array([0.04, 0.035, 0.07, 0.27, 0.48])
E0 = np.array([0.9, 1.1, 1.2, 1.0, 0.8])
RESP = np.array([[0.0, 0.1, 2.0], [0.1, 1.5, 0.5], [0.4, 2.0, 0.1], [1.8, 0.3, 0.0],
                 [1.0, 0.0, 0.0]])
T_CENTRES = np.linspace(-1.2, 1.2, N)
MATS = np.array([np.full(N, 0.18), np.linspace(0.05, 0.6, N)])


def medium(**over):
    """``shade_gbuffer``'s medium keywords, with ``over`` replacing some."""
    m = dict(a=A, b=B, kd=KD, e0=E0, response_weights=RESP, material_bands=MATS,
             sigmoid_centers_t=T_CENTRES, ambient="cosine")
    m.update(over)
    return m
