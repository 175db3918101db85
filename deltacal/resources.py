"""The memory a process may use, and a check before building a large problem.

numpy raises MemoryError only once an allocation fails, which on Linux with overcommit may be
long after the machine has gone into swap. A problem whose size is known up front (the rows
of an identification) is estimated first and refused in one line when it cannot fit.
"""

from __future__ import annotations

import resource

from .exceptions import ResourceError

#: Part of the available memory a problem may take: the rest is for the interpreter, the
#: libraries and the other processes.
SHARE = 0.8


def available_memory() -> float:
    """Bytes this process may still allocate.

    The least of the system's available memory and what its address-space limit
    (``ulimit -v``) leaves beyond what the process maps already.
    """
    limits = []
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    limits.append(int(line.split()[1]) * 1024.0)
                    break
        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft != resource.RLIM_INFINITY:
            with open("/proc/self/statm", encoding="ascii") as f:
                used = int(f.read().split()[0]) * resource.getpagesize()
            limits.append(float(soft - used))
    except (OSError, ValueError, IndexError):
        pass
    return min(limits) if limits else float("inf")


def require_memory(needed: float, what: str, advice: str) -> None:
    """Refuse a problem whose estimated size does not fit the memory available.

    Args:
        needed: Estimated peak memory of the problem [bytes].
        what: What the problem is, for the message ("identify from 200,000 positions").
        advice: What to do instead.

    Raises:
        ResourceError: ``needed`` exceeds :data:`SHARE` of :func:`available_memory`.
    """
    available = available_memory()
    if needed > SHARE * available:
        raise ResourceError(
            f"{what} needs about {needed / 2**30:.3g} GB of memory and {available / 2**30:.3g} GB is "
            f"available: {advice}",
            needed,
            available,
        )
