"""The analysis appended to docs/benchmarks.md by the full run.

Static text: it refers to the tables above by section, and quotes only
figures that were measured once during development (said so where it does).
"""

NOTES = r'''
## 7. Findings

### 7.1 The n = 64 target: the Riccati route of the package

* **Plain cvxpy + Clarabel does not fit** (§2a): peak memory grows like
  about n³ and one interior-point iteration like n⁴·⁵–n⁵; at n = 64 the
  build dies in the capped subprocess. Clarabel stores and factors a dense
  s(s+1)/2 block per PSD cone (s = 2n + m1 after its chordal split).
  CVXOPT grows like n⁴ and SCS needs its tolerance tightened to 1e-6 and
  tens of thousands of iterations before the exact check passes (§2b).
* **What the package does now** (`control_ncs/riccati.py`): when the gain
  sees the whole state at every phase (`structure='full'`: the static gain
  with the zero actuator and no sensor schedule, any actuator schedule),
  `Θ_k ≺ 0` is, after a Schur complement on its `w` block, the Riccati
  inequality `r² P_k ≻ G_k(K; P_{k+1})`, whose Loewner minimiser over `K`
  is explicit. The backward iteration from `P = 0` is monotone and bounded
  by every strict solution of the LMI, so it converges exactly when the LMI
  (with its margin) is feasible; η is maximised by a warm-started
  bisection. `passivesyn` takes this route by itself above
  `synthesis.RICCATI_THRESHOLD` = 8 states (no solver options given), or
  with `solver='riccati'`; every gain then passes the same exact
  `check_certificate` as the LMI's. §2b is the default call.
* **Cost**: O(N·M·n³) per sweep, O(N·n²) memory, no cvxpy. The stopping
  rule is itself a proof: after a sweep only the phase that wraps around the
  period can violate the inequality, and one Cholesky factorisation there
  shows `Θ_k ≺ 0` for the current `(P, K)`.
* **Its limits**: near the supremum of η the iteration converges
  sublinearly; a bisection level not converged after `probe_sweeps`
  sweeps counts as infeasible, so the maximised η lies up to about the
  bisection tolerance (1e-4 relative) below the LMI's (§1b). A level that
  runs out of sweeps is reported as inconclusive (`'solver_failed'`), not
  infeasible; when the route was chosen automatically and the plant has at
  most 16 states, `passivesyn` then solves the LMI. Structured loops (sensor
  schedules, the predictor, the hold actuator whose gain does not see the
  whole state) have no Loewner minimiser over a structured `K` and stay on
  the LMI, so for them the n = 64 limit of §2a still applies. A
  Newton/Kleinman step on the same operator would converge quadratically
  near the supremum; not done.

### 7.2 cvxpy's compile time: every LMI shape compiled once

Every LMI is built from `cvxpy.Parameter`s (DPP: the plant data enter as
pre-multiplied parameters such as √p·A, the analysis LMI's `Σ p GᵀPG` as a
parameter matrix acting on the triangle of `P`) and the compiled problem of
each shape is kept (`lmi.CACHE_SIZE` = 6 per thread, least recently used
dropped). A second call with a plant of the same shape, a retry of
`passivesyn`, an η sweep or a sweep over loss probabilities only reloads
parameter values: §1 (warm columns) and §2c. The first call of a shape still
compiles (cold columns of §1); at n = 4 that first compilation is most of a
single call, and it cannot be avoided short of bypassing cvxpy.

### 7.3 The four-row form is not 4× slower: Clarabel already exploits it

§1 and §1b: with Clarabel's default chordal decomposition the paper form's
mutually-zero mode rows are split off, so both forms become cliques of side
2n + m1 (four per phase in the paper form, two in the merged one); the
measured paper/merged ratio is therefore about 2–4× (growing with n,
shrinking with N), not the (5/3)⁶ ≈ 21× of a dense factorisation. With the
decomposition off (§1b) the ratio is far larger, as the dense count
predicts. The merged form remains the right default; the 4× target is
missed for this reason, not because the merge does not work, and no
further gain is available from the merge itself. Clarabel's multithreaded
`faer` KKT solver (§1b) speeds up the larger LMIs but is not the default:
on a structurally infeasible plant of the test suite it returned 'optimal'
with an answer the exact check refused.

### 7.4 Passivity index of a given system

§5: for a deterministic system the package no longer solves an SDP. The
KYP frequency test (vectorised over one complex Schur form of `A`) gives an
upper bound ν̂; just below it the KYP inequality, with its `w` block
eliminated, is a discrete algebraic Riccati equation with cross term
(`scipy.linalg.solve_discrete_are` with `Q = −εI`, `S = Cᵀ`,
`R = D + Dᵀ − 2ηI`, `X = −P`); its stabilising solution is the certificate,
and `certify_index` checks it exactly. If it does not certify, the level is
lowered, a missed resonance is located by the unit-circle eigenvalues of
the symplectic pencil, and as a last resort the LMI is solved
(`method='auto'`); `method='lmi'` keeps the old route. Lossy and periodic
systems of up to 8 states are still certified by the LMI: a Riccati
iteration for them converges slowly near the supremum (development runs:
1–8 s at n ≤ 6, 2e-6 to 1.4e-5 below the KYP value). Above 8 states the
coupled iteration of `riccati_synthesis`, on the loop without control
input, is the default (the delayed-design section: 41.8× faster than the
LMI at 58 states, η 1e-4 relative below, the same exact check).

### 7.5 simulate against the per-trial loops

§4: `simulate` no longer groups trials by mode. Per phase, each mode's
matrices differ from the most probable one by a low-rank term
(`U_i V_i`; rank 2 for the benchmark's loss model), so one step is one
matrix product `[z; ξ⁺] = [M_b U][ξ; w; s]` for all trials, with
`s = mask ∘ V[ξ; w]` and a 0/1 mode mask drawn in bulk. The paths are
written in place into one time-major array and exposed as
`[signal, trial, time]` views: no transpose copy, and the
`TimeResponseData` is built without copying them. Each product is kept
small enough that OpenBLAS stays on one thread (on the shared 2-core
machine a threaded product of this size was 70× slower in development);
instead, chunks of trials run side by side on the available cores
(`workers=`, default: one thread per CPU; numpy releases the GIL in the
products, and every chunk writes its own trials from its own random
stream, so the paths do not change — tested). In development this gave
1.3× at n = 32 and 5000 trials on the 2 cores.
At n = 32 the remaining cost is memory traffic: about 38 floats written
per trial-step at ≈ 2.8 ns each for fresh pages (measured in development),
plus the product; that bounds one core near 6 M trial-steps/s, so the
50× target at n = 32 rests on the second core and on how fast the baseline
happens to run in the same round. Both baselines are single-threaded
Python loops.

### 7.6 Left as it is

* n = 24 with N = 4 and N = 10 in §1 (the merged LMI alone takes over two
  minutes at N = 4); the default call takes the Riccati route there.
* Large *structured* designs (sensor schedules, predictor) still go through
  the LMI: at n ≳ 24 they take minutes, at n = 64 they do not fit.
* The exact ms_radius inside every certificate check is dense up to n = 24
  and matrix-free above; for deterministic systems it is now ρ(Φ)^(2/N)
  from the n×n monodromy.

## One chain per link: before and after, the same calls

`python -m benchmarks.before_after OLD NEW --rounds 3` times six user calls
(a 4-state plant, two measurements, one input; `benchmarks/before_after.py`)
in a fresh interpreter per tree, the trees alternating, least of 3 calls ×
3 rounds. *Before*: the tree just before links became chains (7c5cf79^,
delayed links on their own builder); *reshaped*: after one chain per link,
one builder and the synthesis package (2140601); *now*: main today (the
certified radius, the tight ℓ2 gain and everything since). One run, load
average about 6 on the 2-core machine (other work running), so ratios
within ±30 % are noise.

| call | before | reshaped | now | reshaped / before | now / before |
|---|---|---|---|---|---|
| `feedback`, Bernoulli links | 0.49 ms | 1.43 ms | 1.22 ms | 2.9 | 2.3 |
| `ms_radius`, Bernoulli links | 0.15 ms | 0.15 ms | 0.72 ms | 1.0 | 4.8 |
| `feedback`, a delayed sensor link | 0.65 ms | 3.0 ms | 2.2 ms | 4.6 | 3.5 |
| `norm(·, 2)`, a delayed sensor link | 1,870 ms | 6.2 ms | 164 ms | 0.003 | 0.09 |
| `h2syn`, a sensor schedule | 49 ms | 195 ms | 244 ms | 4.0 | 3.3 |
| `passivesyn`, Bernoulli links | 36 ms | 34 ms | 56 ms | 0.95 | 1.3 |

What the ratios say:

* **Building a loop costs about a millisecond more.** The builder now forms
  both links' chains and their product and writes every mode from what the
  chain states emit (a profile of 200 calls spreads the time over small
  numpy operations: the plan, the chain objects, the mode matrices, the
  JumpStateSpace checks; no single cost dominates). A delayed loop is built
  in 2–3 ms instead of 0.7 ms, and it is now the right loop: the old
  builder dropped the other link's loss.
* **`ms_radius` carries a proof now** (the certified bracket of the
  Collatz–Wielandt probes, about 0.6 ms on this loop); *reshaped* still
  returned a point. That is the whole 4.8×.
* **`norm(·, 2)` over a delayed link** was slow before (1.9 s: the old
  delayed route); *reshaped* answered in 6 ms with a point radius; *now*
  certifies the loop mean-square stable first (a bracket on the
  matrix-free route: 8 modes of 12 states), 164 ms.
* **`h2syn` with a sensor schedule** returns the same gain and the same
  H2 norm, 1.13645, in every tree. It now starts its local search from the
  full-information H2 optimum of the same open loop, projected on what the
  gain reads — one convex program per call, compiled once per process —
  and certifies the loop it returns; that program is most of the 4×.
* **`passivesyn`** on Bernoulli links is unchanged within the noise.
'''
