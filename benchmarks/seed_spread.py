"""How much a ratio of two filters' mean errors moves with the seeds (used by run_experiments and
compare_results). Runs are paired by seed: the same simulated bag for both filters."""

import numpy as np

MIN_SEEDS = 5  # below this a bootstrap over seeds says nothing


def paired(top, bottom):
    """The seeds in both {seed: value} maps, sorted, and the two value arrays in that order."""
    seeds = sorted(set(top) & set(bottom))
    return seeds, np.array([top[s] for s in seeds]), np.array([bottom[s] for s in seeds])



def ratio_interval(top, bottom, draws=2000, level=0.90):
    """A bootstrap interval of mean(top) / mean(bottom) over the seeds in both: seeds drawn with
    replacement, each seed's pair of runs kept together; (nan, nan) with fewer than MIN_SEEDS
    such seeds or a non-finite value."""
    _, t, b = paired(top, bottom)
    if len(t) < MIN_SEEDS or not (np.all(np.isfinite(t)) and np.all(np.isfinite(b))):
        return float("nan"), float("nan")
    picks = np.random.default_rng(0).integers(0, len(t), size=(draws, len(t)))
    with np.errstate(divide="ignore", invalid="ignore"):
        boot = t[picks].mean(axis=1) / b[picks].mean(axis=1)
    boot = boot[np.isfinite(boot)]
    if len(boot) == 0:
        return float("nan"), float("nan")
    tail = 50.0 * (1.0 - level)
    low, high = np.percentile(boot, [tail, 100.0 - tail])
    return float(low), float(high)


def block_ratios(top, bottom, block=10):
    """The ratio over each block of `block` consecutive common seeds: [(first, last, ratio)]."""
    seeds, t, b = paired(top, bottom)
    return [(seeds[k], seeds[k + block - 1], t[k:k + block].mean() / b[k:k + block].mean())
            for k in range(0, len(seeds) - block + 1, block)]
