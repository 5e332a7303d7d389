"""Input limits and bounded reading: every input is checked before memory is spent on it.

The limits (stated in the README):

==========================  =================================================================
BVH file size               at most :data:`MAX_BVH_BYTES` (2 GiB), checked before reading
BVH lines                   at most :data:`MAX_LINES` (counted on the bytes, before splitting)
BVH frames (``Frames:``)    at most :data:`MAX_FRAMES` (1,000,000)
BVH values (frames x chan.) at most :data:`MAX_VALUES` (120,000,000 = 960 MB of float64; a
                            70-minute take at 120 fps with 159 channels has 80 million)
BVH joints, nesting depth   at most :data:`MAX_JOINTS` (1024) joints, :data:`MAX_DEPTH` (256) deep
BVH joint name              at most :data:`MAX_NAME` (255) characters
BVH numbers                 finite, ``abs(x) <= MAX_ABS_VALUE`` (1e7: 10 km in mm, 27,000 turns)
Frame Time                  :data:`FRAME_TIME_RANGE`: 0.0001 s .. 10 s (10,000 fps .. 0.1 fps)
Splice                      each take has >= 2 frames; the hands take resampled to the body's
                            rate has at most :data:`MAX_DURATION_RATIO` (20) times the body's
                            frames and at most :data:`MAX_FRAMES`
Constraints file (YAML)     at most :data:`MAX_YAML_BYTES` (1 MiB); no tags (``!foo``,
                            ``!!float``); at most :data:`MAX_YAML_NODES` (100,000) nodes after
                            alias expansion; nesting at most :data:`MAX_YAML_DEPTH` (32);
                            scalars at most :data:`MAX_YAML_SCALAR` (256) characters;
                            frame numbers and times at most :data:`MAX_FRAME_NUMBER` frames
Messages                    one line; a quoted token is cut to :data:`TOKEN_CHARS` (60)
                            characters + '…'; a whole message to :data:`MESSAGE_CHARS` (400)
==========================  =================================================================

Inputs that are not regular files: a pipe or process substitution (``<(cat body.bvh)``) is
read once, up to the size limit; a character device (``/dev/zero``), a block device or a
socket is refused without reading.
"""

from __future__ import annotations

import io
import os
import stat

__all__ = ["MAX_BVH_BYTES", "MAX_LINES", "MAX_FRAMES", "MAX_VALUES", "MAX_JOINTS", "MAX_DEPTH", "MAX_NAME",
           "MAX_ABS_VALUE", "FRAME_TIME_RANGE", "MAX_DURATION_RATIO", "MAX_YAML_BYTES", "MAX_YAML_NODES",
           "MAX_YAML_DEPTH", "MAX_YAML_SCALAR", "MAX_FRAME_NUMBER", "TOKEN_CHARS", "MESSAGE_CHARS",
           "shorten", "one_line", "read_input"]

MAX_BVH_BYTES = 2 * 1024 * 1024 * 1024
MAX_FRAMES = 1_000_000
MAX_LINES = MAX_FRAMES + 100_000
MAX_VALUES = 120_000_000
MAX_JOINTS = 1024
MAX_DEPTH = 256
MAX_NAME = 255
MAX_ABS_VALUE = 1e7
FRAME_TIME_RANGE = (1e-4, 10.0)  # seconds
MAX_DURATION_RATIO = 20.0
MAX_YAML_BYTES = 1024 * 1024
MAX_YAML_NODES = 100_000
MAX_YAML_DEPTH = 32
MAX_YAML_SCALAR = 256
MAX_FRAME_NUMBER = 10**9
TOKEN_CHARS = 60
MESSAGE_CHARS = 400


def shorten(token, limit: int = TOKEN_CHARS) -> str:
    """``repr(token)`` cut to about ``limit`` characters with a trailing '…' (for messages)."""
    s = str(token)
    if len(s) > limit:
        return repr(s[:limit]) + "…"
    return repr(s)


def one_line(message: str, limit: int = MESSAGE_CHARS) -> str:
    """``message`` on one line (line breaks become spaces), cut to ``limit`` characters."""
    s = " ".join(str(message).split())
    return s if len(s) <= limit else s[: limit - 1] + "…"


#: :func:`read_input` reads a regular file in pieces of this many bytes (and reports progress after each)
READ_PIECE = 16 << 20


def read_input(path: str | os.PathLike, *, max_bytes: int, error, what: str = "file",
               progress=None) -> bytes | bytearray:
    """The bytes of an input file, read once and never more than ``max_bytes``.

    Parameters
    ----------
    path : path of a regular file or a pipe (FIFO, process substitution).
    max_bytes : int
        Larger inputs are refused (a regular file by its size, before reading).
    error : callable
        ``error(message) -> Exception`` raised for every problem (file not found, a device...).
    what : str
        The kind of file, for messages ("BVH file", "constraints file").
    progress : callable, optional
        ``progress(fraction of the file's size read)`` after each :data:`READ_PIECE` bytes (regular files).
    """
    try:
        # O_NONBLOCK: opening a FIFO that no program writes to must not wait forever.
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise error("file not found") from None
    except IsADirectoryError:
        raise error(f"is a directory, expected a {what}") from None
    except PermissionError:
        raise error("permission denied: cannot read the file") from None
    except OSError as e:
        raise error(f"cannot open the file: {e.strerror or e}") from None
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise error(f"is a directory, expected a {what}")
        if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) or stat.S_ISSOCK(st.st_mode):
            kind = {stat.S_ISCHR: "a character device", stat.S_ISBLK: "a block device",
                    stat.S_ISSOCK: "a socket"}
            name = next(v for f, v in kind.items() if f(st.st_mode))
            raise error(f"is {name}, not a {what}; give a regular file or a pipe")
        if stat.S_ISREG(st.st_mode) and st.st_size > max_bytes:
            raise error(f"the file is {st.st_size:,} bytes, more than the limit of {max_bytes:,} bytes")
        if stat.S_ISFIFO(st.st_mode):  # read the pipe to its end (EOF at once if nobody writes)
            os.set_blocking(fd, True)
        # a regular file is read into a buffer of its size (growing one by appending copies a
        # 1 GB take several times over: 2.6 s of its 4.3 s); a pipe, or a file that grows
        # while it is read, appends
        size = st.st_size if stat.S_ISREG(st.st_mode) else 0
        buf = bytearray(size)
        view = memoryview(buf)
        raw = io.FileIO(fd, "rb", closefd=False)  # readinto: no copy of each piece
        got = 0
        while got < size:
            n = raw.readinto(view[got:got + READ_PIECE])
            if not n:
                break
            got += n
            if progress is not None:
                progress(got / size)
        view.release()
        if got < size:  # the file shrank while it was read
            del buf[got:]
        while True:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - len(buf)))
            if not chunk:
                break
            buf += chunk
            if len(buf) > max_bytes:
                raise error(f"the input is more than the limit of {max_bytes:,} bytes")
        return bytes(buf) if len(buf) < (1 << 20) else buf  # a bytearray avoids a copy of a large input
    except OSError as e:
        raise error(f"cannot read the file: {e.strerror or e}") from None
    finally:
        os.close(fd)


def is_regular_file(path) -> bool:
    """Whether ``path`` is a regular file (following symbolic links)."""
    try:
        return stat.S_ISREG(os.stat(path).st_mode)
    except (OSError, ValueError):
        return False


def check_takes(body, hands) -> None:
    """Refuse a body/hands pair the splice cannot handle within bounded time and memory.

    Each take needs at least 2 frames; the hands take brought to the body's frame rate must
    have at least 2 and at most ``MAX_DURATION_RATIO`` times the body's frames (and at most
    ``MAX_FRAMES``).  Raises :class:`~splicer.errors.SplicerError` naming the file.
    """
    from ..errors import SplicerError

    for m, who in ((body, "body"), (hands, "hands")):
        if m.n_frames < 2:
            raise SplicerError(f"{m.source or who}: the {who} take has {m.n_frames} frame(s); "
                               "splicing needs at least 2")
    n = body.n_frames
    resampled = (hands.n_frames - 1) * hands.frame_time / body.frame_time + 1
    dur_b = (n - 1) * body.frame_time
    dur_h = (hands.n_frames - 1) * hands.frame_time
    if resampled < 2:
        raise SplicerError(f"{hands.source or 'hands'}: the hands take lasts {dur_h:.3g} s, less than one body "
                           f"frame ({body.frame_time:.3g} s)")
    if resampled > MAX_DURATION_RATIO * n or resampled > MAX_FRAMES:
        raise SplicerError(f"{hands.source or 'hands'}: the hands take lasts {dur_h:.4g} s and the body take "
                           f"{dur_b:.4g} s; they cannot show the same performance (the hands take may last at "
                           f"most {MAX_DURATION_RATIO:g} times as long)")
