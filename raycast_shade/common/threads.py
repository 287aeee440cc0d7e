"""The threading default: how Numba's OpenMP workers wait between kernels.

A frame is a dozen short parallel kernels. Under GNU OpenMP's default wait
policy a worker spins after each one, for about 300,000 iterations, before
it sleeps; on a loaded machine the spin takes a core from the other
processes and from the next kernel's own work, and two threads took up to
1.9x as long as one (docs/performance.md, "A loaded machine").
``OMP_WAIT_POLICY=PASSIVE`` makes idle workers sleep at once: two threads
then never took longer than one beyond the noise, loaded or not, and the
2-thread frame was the fastest of the policies measured or within 5% of it.
The ``workqueue`` layer does as well, but Numba documents it as not
thread-safe (the batch app renders in a Dask worker's executor threads), so
the library keeps Numba's layer choice and sets only the wait policy.

GNU OpenMP reads the variable once, when Numba first launches a parallel
kernel and loads it, so the default is set at package import (before any
kernel of ours runs). The user's choice wins: nothing is set when
``OMP_WAIT_POLICY`` or ``GOMP_SPINCOUNT`` is already in the environment.
The variable is inherited by child processes, as any setting of the
environment is.

Other thread pools in the process. ``OMP_WAIT_POLICY`` is read by every
OpenMP runtime when it loads (the variable is OpenMP's own, not GNU's), so
a library imported after this package -- a second GNU OpenMP bundled in a
wheel (FLIP's, pycolmap's), an Open3D built with OpenMP -- sleeps its idle
workers too. A runtime loaded before keeps the
policy it read, and a worker it leaves spinning takes a core from the next
frame; nothing inside the process can change that afterwards, so the remedy
is the user's: ``OMP_WAIT_POLICY=PASSIVE`` (or ``KMP_BLOCKTIME=0`` for an
Intel runtime) in the environment before Python starts, or ``import
raycast_shade`` first (docs/performance.md, "Another library's threads").
The Open3D 0.20 wheel uses TBB, not OpenMP. The library sets nothing else:
the threading layer stays Numba's choice.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping

__all__ = ["WAIT_POLICY", "USER_KEYS", "apply_wait_policy"]

WAIT_POLICY = "PASSIVE"
USER_KEYS = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")  # either one means the user chose


def apply_wait_policy(environ: MutableMapping[str, str] | None = None) -> bool:
    """Set ``OMP_WAIT_POLICY=PASSIVE`` in ``environ`` unless the user chose a wait.

    Parameters
    ----------
    environ : mutable mapping, optional
        The process environment (``os.environ``) by default.

    Returns
    -------
    bool
        True when the default was set, False when the user's choice was kept.
    """
    environ = os.environ if environ is None else environ
    if any(key in environ for key in USER_KEYS):
        return False
    environ["OMP_WAIT_POLICY"] = WAIT_POLICY
    return True
