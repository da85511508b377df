"""Rate limits and refusal counters of the web stack (ROS-free, aiohttp-free).

:class:`TokenBuckets` limit requests per key (an address, a session): each key may send ``burst`` requests
at once and ``rate`` per second on average; the buckets of the least recently seen keys are forgotten
beyond ``max_keys`` (a flood of addresses costs bounded memory). :class:`Counters` count what was refused,
by reason, for the page and the diagnostics.
"""

from __future__ import annotations

from collections import OrderedDict


class TokenBuckets:
    def __init__(self, rate: float, burst: float, max_keys: int = 10000) -> None:
        if not (rate > 0 and burst >= 1):
            raise ValueError(f"rate {rate!r} must be > 0 and burst {burst!r} >= 1")
        self.rate, self.burst, self.max_keys = float(rate), float(burst), max_keys
        self._buckets: OrderedDict[str, tuple[float, float]] = OrderedDict()   # key -> (tokens, at)

    def take(self, key: str, now: float, cost: float = 1.0) -> bool:
        """Take ``cost`` tokens from ``key``'s bucket; False (nothing taken) when it has too few."""
        tokens, at = self._buckets.pop(key, (self.burst, now))
        tokens = min(self.burst, tokens + max(0.0, now - at) * self.rate)
        ok = tokens >= cost
        self._buckets[key] = (tokens - cost if ok else tokens, now)
        while len(self._buckets) > self.max_keys:
            self._buckets.popitem(last=False)
        return ok


class Counters(dict):
    """Named counters: ``refused_<reason>`` for every refused request, and a few totals."""

    def inc(self, key: str, n: int = 1) -> None:
        self[key] = self.get(key, 0) + n

    def refused(self) -> int:
        return sum(v for k, v in self.items() if k.startswith("refused_"))
