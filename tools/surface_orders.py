"""What each order of scattering adds to the colour of deep water seen from above.

Iwasaki, Dobashi and Nishita (2003, seed 002) add second-order scattering to
the single scattering of their sea seen from above and report deep water
coming out bluer. aquaspec's light field solves all orders at once; this
tool splits the same water's light into orders to measure what each adds.

Method: successive orders of scattering in the plane-parallel, azimuthally
averaged problem that :func:`aquaspec.transport.lightfield.solve.solve_lightfield`
solves (its nodes, split at Snell's window, its delta-M scaled water ``c*``,
``b*`` and redistribution), under the flat surface and a uniform sky, in
deep water. Order 0 is the sky's light through the surface, unscattered;
order ``k`` is driven by the source ``b* Q L_{k-1}`` and carried along each
node's direction with exact exponential steps (the source linear between
depth nodes); the light of order ``k`` going up and reaching the surface is
mirrored back down within the same order (reflection is not scattering).
The sum over orders is checked against the light field's own solution.
Printed per water: the nadir water-leaving radiance's camera RGB (the
``nikon-5100-npl`` sensor) after 1, 2, 3 orders and all of them, its
blue/green ratio and hue angle.

Usage::

    python tools/surface_orders.py [WATER ...]      # default I IB II 3C
"""

from __future__ import annotations

import sys

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.medium.interface import below_surface, snell_window_cos
from aquaspec.medium.phase_bands import band_moments, redistribution_matrix
from aquaspec.medium.water import load_water
from aquaspec.transport.lightfield.solve import hemisphere_nodes, solve_lightfield
from aquaspec.validation.metrics import rgb_to_hsv

N_STREAMS = 32
ORDERS = 60


def _march(source, c, mu, z, start):
    """Radiance along direction cosines ``mu`` (all down or all up, (m,))
    through depth nodes ``z``, (m, nz): ``dL/ds = -c L + J`` with ``J``
    (m, nz) linear between nodes; going down from ``start`` (m,) at the
    surface, going up from 0 at the deep bottom."""
    m, nz = source.shape
    out = np.zeros((m, nz))
    tau = c * np.diff(z)[None, :] / np.abs(mu)[:, None]
    e = np.exp(-tau)
    # Exact integral of a linear source over one step, weights of its ends.
    w_far = np.where(tau > 1e-8, (1 - e) / np.maximum(tau, 1e-300) - e, 0.5 * tau) / c
    w_near = np.where(tau > 1e-8, 1 - (1 - e) / np.maximum(tau, 1e-300), 0.5 * tau) / c
    if mu[0] > 0:                                # down: from the surface
        out[:, 0] = start
        for k in range(nz - 1):
            out[:, k + 1] = (e[:, k] * out[:, k] + w_far[:, k] * source[:, k]
                             + w_near[:, k] * source[:, k + 1])
    else:                                        # up: from the deep bottom
        for k in range(nz - 2, -1, -1):
            out[:, k] = (e[:, k] * out[:, k + 1] + w_far[:, k] * source[:, k + 1]
                         + w_near[:, k] * source[:, k])
    return out


def orders_at_nadir(a, b, wavelength_nm, phase="petzold"):
    """Nadir upwelling radiance just below the surface per order (ORDERS,)
    for one band and the light field's all-orders value, both per unit of the
    sky's radiance scale (the window's radiance is that times ``T``)."""
    window = snell_window_cos()
    mu_up, w_up = hemisphere_nodes(N_STREAMS, window)
    mu = np.concatenate([mu_up, -mu_up])
    w = np.concatenate([w_up, w_up])
    n = N_STREAMS
    chi = band_moments(phase, 2 * n, b=np.array([b]), wavelength_nm=np.array([wavelength_nm]))
    f = max(float(chi[0, 2 * n]), 0.0)
    chi_star = (chi[:, : 2 * n] - f) / (1 - f)
    c_star, b_star = a + b - f * b, (1 - f) * b
    q = redistribution_matrix(chi_star, mu, mu, np.ones_like(mu))[0]
    q = q / (q @ w)[:, None]                          # as the solver renormalises
    q = q * w[None, :]                                # source = b* sum_j q_ij L_j
    sky, mirror, _ = below_surface(mu_up, "fresnel")
    z = np.linspace(0.0, 30.0 / c_star, 3001)
    prev = np.zeros((2 * n, z.size))
    prev[:n] = sky[:, None] * np.exp(-c_star * z[None, :] / mu_up[:, None])
    nadir = []
    for _ in range(ORDERS):
        src = b_star * (q @ prev)
        cur = np.zeros_like(prev)
        cur[n:] = _march(src[n:], c_star, mu[n:], z, None)
        cur[:n] = _march(src[:n], c_star, mu[:n], z, mirror * cur[n:, 0])
        nadir.append(cur[n, 0])
        prev = cur
    lf = solve_lightfield([a], [b], phase=phase, wavelength_nm=[wavelength_nm],
                          surface="fresnel", n_streams=n)
    full = float(lf.node_radiance(0.0)[0][n]) / float(lf.top_radiance[0])
    return np.array(nadir), full


def main(waters):
    bands = Bands(16)
    sensor = get_sensor("nikon-5100-npl")
    wts = sensor.band_weights(bands)
    print("nadir water-leaving colour of deep water under an overcast sky, by orders "
          "(Petzold's particles, 16 bands, nikon-5100-npl)")
    for name in waters:
        water = load_water(name)
        a = bands.average(water.wavelength_nm, water.a)
        b = bands.average(water.wavelength_nm, water.b)
        per = []
        fulls = []
        for i in range(bands.n):
            orders, full = orders_at_nadir(a[i], b[i], bands.centers_nm[i])
            per.append(orders)
            fulls.append(full)
        per = np.array(per)                           # (bands, ORDERS)
        rows = {"1": per[:, :1].sum(1), "1-2": per[:, :2].sum(1), "1-3": per[:, :3].sum(1),
                f"1-{ORDERS}": per.sum(1), "light field": np.array(fulls)}
        print(f"\nJerlov {name}: sum of orders / light field per band "
              f"{np.round(rows[f'1-{ORDERS}'] / rows['light field'], 3).tolist()}")
        ref = rows["light field"] @ wts
        for label, val in rows.items():
            rgb = val @ wts
            hue = float(np.degrees(rgb_to_hsv(rgb[None])[0, 0]))
            print(f"  orders {label:12s} RGB/all {np.round(rgb / ref, 3)}  B/G {rgb[2] / rgb[1]:.3f}"
                  f"  hue {hue:6.1f} deg")


if __name__ == "__main__":
    main(sys.argv[1:] or ["I", "IB", "II", "3C"])
