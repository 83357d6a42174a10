"""Encoding an animation's frames: one palette for every frame of the GIF, and the MP4 through
``ffmpeg`` where it is installed."""

from __future__ import annotations

import contextlib
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from PIL import Image


def ffmpeg() -> str | None:
    """The ``ffmpeg`` on PATH, or None."""
    return shutil.which("ffmpeg")


def encode_mp4(exe: str, frames: Sequence[Image.Image], target: Path, frame_ms: int) -> None:
    """Pipe the frames as raw RGB into ``ffmpeg`` (the executable ``exe``), one at a time, for
    the MP4 ``target`` showing each for ``frame_ms`` milliseconds (its index at the front, so a
    player starts before the whole file is read).

    Raises
    ------
    OSError
        When ``ffmpeg`` fails (with its message).
    """
    width, height = frames[0].size
    command = [exe, "-hide_banner", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24"]
    command += ["-s", f"{width}x{height}", "-r", f"1000/{frame_ms}", "-i", "-"]
    command += ["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p"]
    command += ["-movflags", "+faststart", "-f", "mp4", "-y", str(target)]
    with tempfile.TemporaryFile() as errors:
        encoder = subprocess.Popen(
            command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=errors
        )
        assert encoder.stdin is not None  # stdin=PIPE
        with contextlib.suppress(BrokenPipeError):  # ffmpeg stopped early: its message says why
            for frame in frames:
                encoder.stdin.write(frame.convert("RGB").tobytes())
        with contextlib.suppress(BrokenPipeError):
            encoder.stdin.close()
        code = encoder.wait()
        errors.seek(0)
        message = errors.read().decode(errors="replace").strip()
    if code != 0:
        raise OSError(f"ffmpeg could not write the MP4: {message or f'exit {code}'}")


def quantizer(first: np.ndarray, last: np.ndarray) -> Callable[[np.ndarray], Image.Image]:
    """Map RGB frames onto one palette of the first and last frames' colours (no dither, so the
    static map keeps the same pixels from frame to frame)."""
    both = Image.fromarray(np.vstack([first, last]))
    palette = both.quantize(colors=255, method=Image.Quantize.FASTOCTREE)
    return lambda f: Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE)
