"""LCM transport: publish terrain messages, read the body state. ``lcm`` is imported lazily.

Install with ``pip install 'stereo-terrain[lcm]'``. URLs are LCM provider URLs: the
default ``udpm://239.255.76.67:7667?ttl=0`` is UDP multicast that stays on this host
(``ttl=1`` reaches the robot's LAN); ``memq://`` is in-process only.
"""

from __future__ import annotations

import logging
import math
import select
import threading
from typing import Any

from ..errors import InputError
from ..odometry import Odometry
from .messages import body_state_t, terrain_t

log = logging.getLogger(__name__)

DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0"
DEFAULT_CHANNEL = "STEREO_TERRAIN"


def import_lcm() -> Any:
    """The ``lcm`` module, or :class:`InputError` saying how to install it."""
    try:
        import lcm
    except ImportError:
        raise InputError(
            "LCM is not installed: pip install 'stereo-terrain[lcm]' (or pip install lcm)"
        ) from None
    return lcm


def open_lcm(url: str) -> Any:
    """An ``lcm.LCM`` on ``url``; :class:`InputError` if the provider cannot be opened."""
    from ..native import captured_native_stderr

    lcm = import_lcm()
    try:
        # liblcm prints its own line (e.g. 'Error: LCM provider "x" not found') before it
        # fails: it goes into the message instead of the terminal.
        with captured_native_stderr() as native:
            opened = lcm.LCM(url)
    except (RuntimeError, OSError, ValueError) as exc:
        said = " ".join(line.strip() for line in native.lines() if line.strip())
        raise InputError(
            f"cannot open LCM on {url!r}: {exc}{f' ({said})' if said else ''}; check the URL "
            f"(e.g. {DEFAULT_URL}) and that multicast is routed (on one host: ttl=0, or "
            "'ip route add 224.0.0.0/4 dev lo')"
        ) from None
    for line in native.lines():
        if line.strip():
            log.warning("liblcm on %s: %s", url, line.strip())
    return opened


class LcmPublisher:
    """Publishes ``terrain_t`` messages on ``channel``; call it with a message."""

    def __init__(self, url: str = DEFAULT_URL, channel: str = DEFAULT_CHANNEL) -> None:
        if not channel:
            raise InputError("the LCM channel name must not be empty")
        self.url, self.channel = url, channel
        self.lc = open_lcm(url)
        self.count = 0

    def __call__(self, msg: terrain_t) -> None:
        self.lc.publish(self.channel, msg.encode())
        self.count += 1


class LcmStateListener:
    """Keeps the latest ``body_state_t`` from ``channel`` (a background thread).

    :meth:`latest` gives ``(Odometry, rpy, utime)`` or None before the first message.
    """

    def __init__(self, url: str = DEFAULT_URL, channel: str = "STATE") -> None:
        self.lc = open_lcm(url)
        self.channel = channel
        self._lock = threading.Lock()
        self._latest: tuple[Odometry, tuple[float, float, float], int] | None = None
        self.received = 0
        self.bad = 0
        self._sub = self.lc.subscribe(channel, self._handle)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lcm-state", daemon=True)
        self._thread.start()

    def _handle(self, channel: str, data: bytes) -> None:
        try:
            msg = body_state_t.decode(data)
        except ValueError:
            self.bad += 1
            return
        rpy = (float(msg.rpy_rad[0]), float(msg.rpy_rad[1]), float(msg.rpy_rad[2]))
        position = [float(v) for v in msg.position_m]
        if not all(math.isfinite(v) for v in (*rpy, *position)):
            self.bad += 1  # a state estimator glitch: keep the last good state
            return
        odo = Odometry(tuple(position), rpy[2], int(msg.utime) * 1e-6)  # type: ignore[arg-type]
        with self._lock:
            self._latest = (odo, rpy, int(msg.utime))
            self.received += 1

    def _run(self) -> None:
        fd = self.lc.fileno()
        while not self._stop.is_set():
            ready, _, _ = select.select([fd], [], [], 0.05)
            if ready:
                self.lc.handle()

    def latest(self) -> tuple[Odometry, tuple[float, float, float], int] | None:
        with self._lock:
            return self._latest

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)
        self.lc.unsubscribe(self._sub)
