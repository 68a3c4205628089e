"""``aquaspec synth``: underwater data sets from RGB-D images, resumable, on a
local pool or a Ray cluster.

One module per concept: the configuration (:mod:`~aquaspec.apps.synth.config`),
the inputs (:mod:`~aquaspec.apps.synth.inputs`), the sampling plan and the
samples' ids (:mod:`~aquaspec.apps.synth.plan`), the files of a sample
(:mod:`~aquaspec.apps.synth.files`), the sample task a worker runs
(:mod:`~aquaspec.apps.synth.task`), the local pool
(:mod:`~aquaspec.apps.synth.local`), the Ray executor
(:mod:`~aquaspec.apps.synth.on_ray`), the manifest and summary
(:mod:`~aquaspec.apps.synth.manifest`), and the run that ties them
(:func:`~aquaspec.apps.synth.run.synth`). docs/synth.md is the guide.
"""

from aquaspec.apps.synth.config import SynthConfig, load_config
from aquaspec.apps.synth.run import synth

__all__ = ["SynthConfig", "load_config", "synth"]
