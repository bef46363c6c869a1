"""Schedules up to symmetry, and the exact tests that prune them.

Two schedules that differ by a rotation of the period or a relabelling of
nodes the plant cannot tell apart certify the same designs, so a search
visits one schedule per orbit: the orbits are counted by Burnside's lemma
and enumerated as necklaces. A schedule is pruned before any synthesis only
by an exact test: the loop never closes, or the lifted pair fails its PBH
test (a mode no scheduled actuator reaches, or no scheduled sensor sees).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from ._lifting import unseen_modes
from .jump import jss
from .plant import NetworkedStateSpace
from .stability import ms_radius

#: Schedules removed before any LMI, each with a proof by exact linear
#: algebra (see :func:`control_ncs.schedule_search`).
LOOP_OPEN = "loop_open"
NOT_STABILISABLE = "not_stabilisable"
NOT_DETECTABLE = "not_detectable"
ESTIMATION_NOT_MSS = "estimation_not_mss"
PRUNE_REASONS = (LOOP_OPEN, NOT_STABILISABLE, NOT_DETECTABLE,
                 ESTIMATION_NOT_MSS)




#: Largest state dimension for which relabelling symmetries are searched
#: (``n!`` permutations are tried, each checked exactly).
RELABEL_MAX_STATES = 8


# -- schedules up to symmetry ---------------------------------------------------

def _loop_closes(sensing: np.ndarray, acting: np.ndarray) -> bool:
    return bool((sensing & acting).any())


def _alphabet(p2: int, m2: int, shared: bool) -> list:
    """The letters ``(sensor, actuator)`` of one phase, in lexicographic
    order (so the order of letters is the order of their indices)."""
    return [(i, j) for i in range(p2 + 1) for j in range(m2 + 1)
            if not (shared and i and j)]


def _necklaces(N: int, k: int):
    """Lexicographically smallest rotations of the words of length ``N``
    over ``0..k-1``, in lexicographic order (Fredricksen-Kessler-Maiorana;
    constant amortised time per necklace)."""
    a = [0] * (N + 1)

    def gen(t: int, p: int):
        if t > N:
            if N % p == 0:
                yield tuple(a[1:])
            return
        a[t] = a[t - p]
        yield from gen(t + 1, p)
        for j in range(a[t - p] + 1, k):
            a[t] = j
            yield from gen(t + 1, t)

    yield from gen(1, 1)


def _min_rotation(word: tuple) -> tuple:
    return min(word[r:] + word[:r] for r in range(len(word)))


def _relabellings(P: NetworkedStateSpace) -> list:
    """Pairs ``(p, s)`` of sensor and actuator permutations under which the
    plant is exactly invariant.

    Sensors are states (``y = x``), so a sensor relabelling is a change of
    state coordinates ``x̃ = Π x`` (``Π = I[p]``); with ``ũ = Σ u`` and a
    relabelling ``Ω`` of ``w`` and ``z`` together (it keeps the supply rate
    ``2 wᵀz − 2η wᵀw``), the plant is unchanged when ``Π A Πᵀ = A``,
    ``Π B1 Ωᵀ = B1``, ``Π B2 Σᵀ = B2``, ``Ω C1 Πᵀ = C1``, ``Ω D11 Ωᵀ = D11``
    and ``Ω D12 Σᵀ = D12`` hold in exact arithmetic; then a schedule and its
    relabelled image pose the same synthesis problem. Identity only when
    ``y ≠ x`` or ``n > RELABEL_MAX_STATES``.
    """
    n, m2, m1 = P.nstates, P.ncon, P.B1.shape[1]
    ident = (tuple(range(n)), tuple(range(m2)))
    if (P.nmeas != n or not np.array_equal(P.C2, np.eye(n))
            or n > RELABEL_MAX_STATES or P.C1.shape[0] != m1):
        return [ident]
    A, B1, B2 = np.asarray(P.A), np.asarray(P.B1), np.asarray(P.B2)
    C1, D11, D12 = np.asarray(P.C1), np.asarray(P.D11), np.asarray(P.D12)
    group = set()
    for p in itertools.permutations(range(n)):
        if not np.array_equal(A[np.ix_(p, p)], A):
            continue
        for w in itertools.permutations(range(m1)):
            if not (np.array_equal(B1[np.ix_(p, w)], B1)
                    and np.array_equal(C1[np.ix_(w, p)], C1)
                    and np.array_equal(D11[np.ix_(w, w)], D11)):
                continue
            for s in itertools.permutations(range(m2)):
                if (np.array_equal(B2[np.ix_(p, s)], B2)
                        and np.array_equal(D12[np.ix_(w, s)], D12)):
                    group.add((p, s))
    return sorted(group)


def _letter_maps(group: list, letters: list) -> list:
    """Each relabelling as a permutation of letter indices."""
    index = {a: i for i, a in enumerate(letters)}
    maps = []
    for p, s in group:
        maps.append(tuple(index[(p[i - 1] + 1 if i else 0,
                                 s[j - 1] + 1 if j else 0)]
                          for i, j in letters))
    return maps


def _orbit_count(N: int, maps: list) -> int:
    """Number of schedules up to rotation and relabelling (Burnside).

    A word is fixed by (rotation by r, relabelling h) iff on each of the
    g = gcd(N, r) position cycles of length L = N/g its letter x satisfies
    h^L(x) = x, i.e. the length of x's cycle under h divides L. The
    rotations with gcd g number φ(N/g), so the sum runs over the divisors
    of N: exact (Python ints) and fast for any period.
    """
    cycles = [_cycle_lengths(h) for h in maps]
    total = 0
    for g in _divisors(N):
        L = N // g
        phi = _totient(L)
        for lengths in cycles:
            fixed = sum(1 for c in lengths if L % c == 0)
            total += phi * fixed ** g
    return total // (N * len(maps))


def _cycle_lengths(h: tuple) -> list:
    """The length of the cycle of each letter under the permutation h."""
    out = []
    for x in range(len(h)):
        y, c = h[x], 1
        while y != x:
            y, c = h[y], c + 1
        out.append(c)
    return out


def _divisors(N: int) -> list:
    small = [d for d in range(1, math.isqrt(N) + 1) if N % d == 0]
    return sorted(set(small + [N // d for d in small]))


def _totient(n: int) -> int:
    """Euler's φ(n), by trial division (n is a period)."""
    out, m, p = n, n, 2
    while p * p <= m:
        if m % p == 0:
            while m % p == 0:
                m //= p
            out -= out // p
        p += 1
    if m > 1:
        out -= out // m
    return out


def _big(count: int) -> str:
    """An exact count, or its order of magnitude when it is huge."""
    if count < 10**15:
        return str(count)
    return f"about 10^{count.bit_length() * math.log10(2):.4g}"


def _canonical_schedules(N: int, maps: list, k: int):
    """One representative per orbit: the smallest word of its orbit."""
    others = [h for h in maps if h != tuple(range(k))]
    for word in _necklaces(N, k):
        if all(_min_rotation(tuple(h[x] for x in word)) >= word
               for h in others):
            yield word


def _prune(P: NetworkedStateSpace, s1: np.ndarray, s2: np.ndarray,
           controller: str, actuator: str, sensor_loss: float,
           decay: float | None) -> str | None:
    """The first exact reason why no gain can exist, or None.

    ``s1``, ``s2``: 0/1 patterns ``(N, p2)`` and ``(N, m2)``.
    """
    A, B2 = np.asarray(P.A), np.asarray(P.B2)
    n, N = A.shape[0], s1.shape[0]
    sensing: np.ndarray = np.any(s1, axis=1)
    acting: np.ndarray = np.any(s2, axis=1)
    # passivesyn's own test on the JumpPlant: some phase knows a
    # coordinate and can act (the predictor always knows x̂)
    if not acting.any() or (controller == "static"
                            and not _loop_closes(sensing, acting)):
        return LOOP_OPEN
    # inputs that can act at phase k: a static gain only where a sensor
    # reports too; with 'hold' a held value acts at every phase (a
    # relaxation: the test stays necessary)
    act = s2 & (sensing[:, None] if controller == "static" else True)
    Bk = [B2 * (act.any(axis=0) if actuator == "hold" else act[k])
          for k in range(N)]
    # the lifted pair's PBH test (dual: what the inputs never reach)
    if unseen_modes(A.T, [Bk[N - 1 - j].T for j in range(N)]):
        return NOT_STABILISABLE
    # what the gain hears: the static gain only where an actuator listens
    C2 = np.asarray(P.C2)
    Ck = [(C2 * s1[k][:, None]) * (acting[k] if controller == "static"
                                   else 1.0) for k in range(N)]
    if unseen_modes(A, Ck):
        return NOT_DETECTABLE
    if controller == "predictor":
        # theory: predictor: e⁺ = (I − θ1 Σ1,k+1) A e, a loop no gain can
        # touch; the closed loop's rate is at least its exact rate
        lost, heard = [], []
        for k in range(N):
            S = np.diag(s1[(k + 1) % N].astype(float))
            lost.append(A)
            heard.append((np.eye(n) - S) @ A)
        modes = np.stack([np.stack(lost), np.stack(heard)], axis=1)
        probs = np.tile([sensor_loss, 1.0 - sensor_loss], (N, 1))
        err = jss(modes, np.zeros((n, 1)), np.zeros((1, n)), np.zeros((1, 1)),
                  probs)
        bound = 1.0 if decay is None else min(1.0, decay ** 2)
        if ms_radius(err) >= bound:
            return ESTIMATION_NOT_MSS
    return None
