"""Recording a live view's frames: PNG frames, an MP4 and the run's sidecar.

:class:`FrameRecorder` writes each frame it is given as
``OUTDIR/frame_00000.png`` (atomically: a temporary file renamed into place,
:func:`aquaspec.io.png.write_png`, the frame's pose in its metadata), with
``mp4=True`` also streams it into ``OUTDIR/flight.mp4`` (H.264 through
``imageio-ffmpeg``, the ``view`` extra; written under a temporary name and
renamed when the run ends), and at the end writes ``OUTDIR/run.json``: the
run's parameters and every frame's pose and time.

:func:`save_snapshot` saves one frame of a live view as ``aquaspec render``
saves an image: the PNG as displayed, its linear camera RGB (EXR, or NPY
without OpenEXR) rendered again for the same pose, and a JSON sidecar with
the spectral setup, the camera (pose included) and the display settings, all
written or none (:func:`aquaspec.io.save.save_image`).
"""

from __future__ import annotations

import datetime as _dt
import os
import secrets
from pathlib import Path

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.device import adapter_info
from aquaspec.io.atomic import write_file_atomically
from aquaspec.io.metadata import stamped
from aquaspec.io.png import write_png
from aquaspec.io.save import save_image
from aquaspec.io.sidecar import sidecar_writer

#: The run's sidecar, in the output folder.
RUN_SIDECAR = "run.json"
#: The video's name, in the output folder.
VIDEO_NAME = "flight.mp4"


def frame_name(index: int) -> str:
    """The file name of frame ``index``."""
    return f"frame_{index:05d}.png"


def _video_writer(path: Path, size, fps: float):
    try:
        # deferred: imageio-ffmpeg (the `view` extra) is needed only for --mp4
        import imageio_ffmpeg
    except ImportError:
        raise AquaspecError("an MP4 needs imageio-ffmpeg; install the view extra: "
                            "pip install 'aquaspec[view]'") from None
    # macro_block_size 2: H.264's 4:2:0 needs even sides, nothing more (no resize).
    gen = imageio_ffmpeg.write_frames(str(path), size, fps=fps, macro_block_size=2)
    gen.send(None)
    return gen


class FrameRecorder:
    """Writes frames, an optional MP4 and the run's sidecar into ``outdir``.

    Parameters
    ----------
    outdir : path
        Made if missing (its parent must exist).
    fps : float
        The video's frame rate.
    mp4 : bool
        Also write :data:`VIDEO_NAME`.
    """

    def __init__(self, outdir, *, fps: float = 30.0, mp4: bool = False):
        self.outdir = Path(outdir)
        if self.outdir.exists() and not self.outdir.is_dir():
            raise AquaspecError(f"--record {str(self.outdir)!r} is a file; accepted: a "
                                "folder (made if missing)")
        if not self.outdir.parent.is_dir():
            raise AquaspecError(f"--record {str(self.outdir)!r}: its parent folder does not "
                                "exist")
        self.outdir.mkdir(exist_ok=True)
        self.fps, self.mp4 = float(fps), bool(mp4)
        self.frames: list[dict] = []
        self._video = None
        self._video_tmp = None

    def add(self, image, info: dict) -> Path:
        """Write ``image`` ((H, W, 3) or (H, W, 4) uint8; alpha dropped) as the
        next frame, ``info`` (JSON-ready: pose, time) in its metadata."""
        rgb = np.ascontiguousarray(np.asarray(image)[..., :3])
        index = len(self.frames)
        path = write_png(self.outdir / frame_name(index), rgb, {"frame": index, **info})
        if self.mp4:
            if self._video is None:
                self._video_tmp = self.outdir / f".{VIDEO_NAME}.{secrets.token_hex(4)}.part.mp4"
                self._video = _video_writer(self._video_tmp, (rgb.shape[1], rgb.shape[0]),
                                            self.fps)
            self._video.send(rgb)
        self.frames.append({"file": path.name, **info})
        return path

    def close(self, params: dict) -> Path:
        """Finish the MP4 and write the run's sidecar (``params`` plus the
        frames); returns the sidecar's path."""
        doc = {**params, "frames": self.frames, "recorded_fps": self.fps}
        if self._video is not None:
            self._video.close()
            os.replace(self._video_tmp, self.outdir / VIDEO_NAME)
            self._video = None
            doc["video"] = VIDEO_NAME
        return write_file_atomically(self.outdir / RUN_SIDECAR, sidecar_writer(stamped(doc)))

    def discard(self) -> None:
        """Drop an unfinished MP4 (after an error)."""
        if self._video is not None:
            self._video.close()
            self._video = None
            self._video_tmp.unlink(missing_ok=True)


def save_snapshot(view, directory) -> dict:
    """Save the live ``view``'s current frame into ``directory`` (module docstring).

    ``view`` is a :class:`aquaspec.apps.live.LiveView` that has drawn a frame.
    The files are ``aquaspec-view-<UTC time>.png`` with ``.png.json`` and
    ``.exr``; returns :func:`aquaspec.io.save.save_image`'s result.
    """
    folder = Path(directory)
    if not folder.is_dir():
        raise AquaspecError(f"save folder {str(folder)!r} does not exist; accepted: an "
                            "existing folder")
    camera = view.camera()
    shown = view.renderer.read_display()
    linear = view.renderer.render_scene(view.shown(camera), camera, view.setup)
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%d-%H%M%S-%f")[:-3]
    base = folder / f"aquaspec-view-{stamp}"
    params = {**view.setup.describe(), "depth_m": camera.depth_m, "camera": camera.describe(),
              "scene": view.view_scene.describe(), "backend": "gpu", "display": view.display_settings,
              "adapter": adapter_info(), "command": "view", "view": view.pose()}
    return save_image(base.with_suffix(".png"), shown, linear, params,
                      linear_path=base.with_suffix(".exr"))
