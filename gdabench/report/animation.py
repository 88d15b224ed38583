"""Animations of a body acting, through the environment's ``render_frames`` hook.

The report rebuilds the run's environment (and controller) from ``run.json`` through its
:class:`~gdabench.experiment.plan.Plan` and asks it for frames of a body, passing the same evaluation seed
and work directory the run used, so a controller that saved its trained policy there can
replay it.  Environments with nothing to show
(``simple``) return None and get no animation.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any, Sequence

import numpy as np
from PIL import Image

from ..body import Body
from ..environment import Controller, Environment
from ..errors import GdabenchError
from ..seeding import evaluation_seed

FPS = 20
MAX_FRAMES = 100
MAX_WIDTH = 400


def frames_to_gif(
    frames: Sequence[Any], *, fps: int = FPS, max_frames: int = MAX_FRAMES, max_width: int = MAX_WIDTH
) -> bytes:
    """Encode RGB frames as a looping GIF, evenly thinned to ``max_frames`` and scaled to ``max_width``."""
    if not len(frames):
        raise GdabenchError("the environment returned no frames")
    keep = np.unique(np.linspace(0, len(frames) - 1, min(max_frames, len(frames))).round().astype(int))
    images = []
    for i in keep:
        array = np.asarray(frames[i])
        if array.ndim != 3 or array.shape[2] not in (3, 4):
            raise GdabenchError(f"frame {i} has shape {array.shape}; expected (height, width, 3) RGB")
        image = Image.fromarray(np.ascontiguousarray(array[..., :3]).astype(np.uint8), "RGB")
        if image.width > max_width:
            image = image.resize(
                (max_width, max(1, round(image.height * max_width / image.width))), Image.Resampling.LANCZOS
            )
        images.append(image.quantize(colors=128, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE))
    duration = round(1000 * len(frames) / len(keep) / fps)  # thinning keeps the real-time pace
    buffer = io.BytesIO()
    images[0].save(
        buffer, format="GIF", save_all=True, append_images=images[1:], duration=duration, loop=0, optimize=True
    )
    return buffer.getvalue()


def animate(env: Environment, controller: Controller | None, body: Body, *, seed: int, workdir: Path) -> bytes | None:
    """A GIF of ``body`` acting in ``env`` as it did in the trial with this seed, or None if the env shows nothing.

    ``workdir`` is the directory the body's evaluation used (see :meth:`gdabench.experiment.plan.Plan.workdir`).
    """
    frames = env.render_frames(body, seed=evaluation_seed(seed, body.hash), controller=controller, workdir=workdir)
    return None if frames is None else frames_to_gif(frames)
