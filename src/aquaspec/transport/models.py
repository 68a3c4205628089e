"""The multiple-scattering models a renderer can choose: a registry.

Each model gives the in-scattered radiance ``L_MS`` along camera rays and the
ambient light on surfaces; the renderer, the GPU passes and the validation
take one by the name the CLI takes (``--ms-model``):

- ``"monzon2022"``: the thesis's analytic model from ``Kd``
  (:mod:`aquaspec.transport.monzon2022`, [Monzon2022] Eq. 4.7); ``"seeds"``,
  the name it had when it was the project's seed, is accepted as an alias.
- ``"lightfield"``: the discrete-ordinates light field with a phase function
  (:mod:`aquaspec.transport.lightfield.solve`), the default.

:func:`ms_model_name` checks a name and returns the canonical one, with an
error that lists what is accepted.

References
----------
.. [Monzon2022] N. Monzon, "Real-time underwater spectral rendering", master
   thesis, Universidad de Zaragoza, 2022.
"""

from __future__ import annotations

from aquaspec.errors import AquaspecError

#: The thesis's analytic model (:mod:`aquaspec.transport.monzon2022`).
MONZON2022 = "monzon2022"
#: The discrete-ordinates light field (:mod:`aquaspec.transport.lightfield.solve`).
LIGHTFIELD = "lightfield"

#: Multiple-scattering models by canonical name: what a renderer calls for
#: L_MS and for the ambient light on surfaces.
MS_MODELS = {
    MONZON2022: "aquaspec.transport.monzon2022.pixel_radiance (l_ms_seeds + AMBIENT_MODELS)",
    LIGHTFIELD: "aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance "
                "(tables from aquaspec.transport.lightfield.bake.lightfield_tables)",
}
#: Other names accepted for a model: alias -> canonical name.
MS_MODEL_ALIASES = {"seeds": MONZON2022}
#: Every name :func:`ms_model_name` accepts (the CLI's choices).
MS_MODEL_CHOICES = (*MS_MODELS, *MS_MODEL_ALIASES)
#: The default: the light field with its forward cone spread over the image
#: (:func:`cone_spread_for`), the model the validation against the path
#: tracer found within 10 % and 1.5 degrees where the thesis's model was
#: 35-75 % off (README, "Accuracy"); ``"monzon2022"`` stays available.
DEFAULT_MS_MODEL = LIGHTFIELD


def ms_model_name(name) -> str:
    """The canonical name of the multiple-scattering model ``name`` (a key of
    :data:`MS_MODELS` or an alias of :data:`MS_MODEL_ALIASES`)."""
    if name in MS_MODELS:
        return name
    try:
        return MS_MODEL_ALIASES[name]
    except (KeyError, TypeError):
        aliases = ", ".join(f"{a} (= {c})" for a, c in MS_MODEL_ALIASES.items())
        raise AquaspecError(f"unknown multiple-scattering model {name!r}; accepted: "
                            f"{', '.join(MS_MODELS)}; aliases: {aliases}") from None


def cone_spread_for(ms_model: str, cone_spread: bool | None) -> bool:
    """Whether the forward cone is spread over the image for ``ms_model``.

    ``cone_spread=None`` means the model's default: on for ``"lightfield"``
    (the configuration the validation measured), off for ``"monzon2022"``
    (which has no forward cone). ``True`` with another model than
    ``"lightfield"`` is an error.
    """
    if cone_spread is None:
        return ms_model == LIGHTFIELD
    if cone_spread and ms_model != LIGHTFIELD:
        raise AquaspecError(f"cone_spread is part of the light-field model; ms_model="
                            f"{ms_model!r}; accepted: ms_model='lightfield' (or no cone spread)")
    return bool(cone_spread)
