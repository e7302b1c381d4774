"""Student's t quantiles for the performance tools' confidence intervals
(tools/perf) and their CI check (tests/perf): one implementation, pure
Python (no scipy on CI machines, no OpenImageIO needed to import it)."""

import functools
import math
from statistics import NormalDist


@functools.lru_cache(maxsize=None)
def t_quantile(p, df):
    """Quantile of Student's t with df degrees of freedom (0.5 < p < 1) by
    bisection on its CDF, the CDF by Simpson integration of the density
    (2000 intervals); closed forms for 1 and 2 degrees of freedom, the
    normal quantile above 200."""
    if df <= 0:
        return float("inf")
    if df == 1:
        return math.tan(math.pi * (p - 0.5))
    if df == 2:
        return (2 * p - 1) / math.sqrt(2 * p * (1 - p))
    if df > 200:
        return NormalDist().inv_cdf(p)
    c = math.exp(math.lgamma((df + 1) / 2) - math.lgamma(df / 2)) / math.sqrt(df * math.pi)

    def cdf(x):
        n = 2000
        h = x / n
        s = 0.0
        for i in range(n + 1):
            t = i * h
            w = 1 if i in (0, n) else (4 if i % 2 else 2)
            s += w * c * (1 + t * t / df) ** (-(df + 1) / 2)
        return 0.5 + s * h / 3

    lo, hi = 0.0, 1.0
    while cdf(hi) < p:
        hi *= 2
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if cdf(mid) < p:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def t975(df):
    """The two-sided 95% quantile of Student's t."""
    return t_quantile(0.975, df)
