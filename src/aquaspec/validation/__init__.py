"""Validation against a spectral path tracer (Mitsuba 3), baselines and metrics.

- :mod:`.reference`: the same scene rendered by Mitsuba 3 (spectral,
  ``volpathmis``) into narrow wavelength bands, and Kd measured in the
  path-traced water with irradiance meters.
- :mod:`.scenes`: the validation scene (the thesis's setting: a camera
  looking horizontally at a ColorChecker board 3 m away in open water).
- :mod:`.metrics`: RMSE, the thesis's HSV distance, SSIM, CIEDE2000.
- :mod:`.baselines`: the RGB (3-band) implementation, Unreal's single-layer
  water, and the per-channel image-formation model.
- :mod:`.study`: waters x depths x cameras, cache, CSV/JSON, plots.
- :mod:`.tyler`: the light-field model's deep radiance distribution against
  Tyler's measurement in Lake Pend Oreille (1958), with no free parameter.
"""
