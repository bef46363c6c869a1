"""The analysis appended to docs/benchmarks.md by the full run.

Static text: it refers to the tables above by section, and quotes only
figures that were measured once during development (said so where it does).
"""

NOTES = r'''
## 7. Findings and proposed package changes

### 7.1 The n = 64 target needs a new route: a certified Riccati iteration

What the tables show:

* **Plain cvxpy + Clarabel does not fit.** §2a: peak memory grows like
  n^3 and one interior-point iteration like n^4.5–5 over n = 16–32 (memory
  steepening to n^3.7 from 32 to 48); at n = 64 the build dies in the
  capped subprocess on a 2.4 GB allocation. During development one
  iteration at n = 48 took 412 s and 14.0 GB (same probe, run once, not in
  the timed run). Clarabel stores and factors a dense s(s+1)/2 block per
  PSD cone (s = 2n + m1 after its chordal split); nothing in the existing
  options changes that.
* **CVXOPT** (`solver='CVXOPT'`) is faster than Clarabel at n = 16 but
  grows like n^4 (§2b: n = 16 → 32); during development the n = 64, N = 4
  run was killed after 400 s at 12.1 GB.
* **SCS** (`solver='SCS', eps=1e-6, max_iters=20000`) with a **fixed η**
  returns a verified gain at n = 64 (§2b) in 80–113 s over four full runs on
  this shared machine: inside the limit, but only just. With **η
  maximised** SCS needs passivesyn's back-off retries (three attempts) and
  is an order of magnitude slower than with η fixed already at n = 16, with
  an η about 1 % below the optimum; at n = 64 it would far exceed the
  limit. **CVXOPT** with η maximised fails (`solver_error`) at n = 16.
* **Prototype (benchmarks/riccati.py)**: with the full state known at every
  phase (`structure='full'`: in the package, the static controller with the
  zero actuator, no sensor schedule, any actuator schedule),
  `Θ_k ≺ 0` is, after a Schur complement on its `w` block, the Riccati
  inequality `r² P_k ≻ G_k(K; P_{k+1})`, where `G_k` is a matrix quadratic in
  `K` with a Loewner-order minimiser `K* = −H⁻¹L`. Iterating
  `P_k ← (G_k(K*; P_{k+1}) + εI)/r²` backwards over the period from
  `P = 0` is monotone and bounded by any strict solution of the LMI, so it
  converges exactly when the LMI is feasible; `η` is maximised by a
  warm-started bisection. Every gain is then checked by the package's own
  `check_certificate` (λmax(Θ_k) < 0 with P_k, and the independent
  ms_radius). Cost per sweep O(N·M·n³), memory O(N·n²), no cvxpy. §2b: a
  verified gain at n = 64, N = 4 in seconds, fixed η or maximised, with or
  without a decay bound; §1b: its maximised η agrees with Clarabel's
  (relative differences ~1e-5 to 1e-4: the bisection stops at rtol 1e-4,
  and the retry back-off of passivesyn lowers the LMI value when the first
  attempt is inaccurate).

**Proposed change** (control_ncs/, for the colleagues who own it): a
`solver='riccati'` route in `passivesyn`, and `'auto'` choosing it for
`structure == 'full'` above n ≈ 24 (where §1 shows Clarabel taking tens of
seconds). The LMI stays the route for `'block'`/`'extended'` (sensor
schedules, the predictor, the hold actuator: the gain sees only part of
the state), where the gain is structured and the Loewner minimiser over
`K` does not exist.

1. New module `control_ncs/riccati.py`: the functions `_Data`, `_wsum`,
   `_step`, `_iterate`, `_search` of benchmarks/riccati.py unchanged
   (about 150 lines, numpy only), plus

```python
def riccati_synthesis(plant, eta, decay, margin=1e-6, rtol=1e-4,
                      max_sweeps=20000):
    """(gains, P, eta_found, SolveReport) for structure 'full'."""
    start = time.perf_counter()
    plant = plant.merged()
    s, N = plant.shape, plant.period
    data = [_Data.of_plant(plant, k) for k in range(N)]

    def gains_of(K):
        g = np.zeros((N, s["nu"], s["nk"]))
        for k in range(N):
            g[k][data[k].act] = K[k]
        return g

    P, K, e, sweeps, bis = _search(
        data, eta, decay, margin, rtol, max_sweeps,
        sup_of=lambda P, K: certified_index(plant.close(gains_of(K)), P,
                                            decay=decay))
    t = time.perf_counter() - start
    return gains_of(K), P, e, SolveReport("optimal", "RICCATI", 0.0, t, t,
                                          sweeps, e)
```

2. In `synthesis.passivesyn`, before the retry loop (the verification that
   follows is the existing one, unchanged):

```python
    if solver is not None and str(solver).upper() == "RICCATI":
        if structure != "full":
            raise ValueError("solver='riccati' needs every state known at "
                             "every phase (structure 'full'); use the LMI")
        try:
            gains, Pcert, e, report = riccati_synthesis(plant, eta, decay)
        except SynthesisError as err:      # the iteration diverged
            raise SynthesisError(f"passivesyn: {err}", "infeasible",
                                 dict(solver="RICCATI")) from None
        CL = plant.close(gains)
        cert = (certify_index(CL, Pcert, decay=decay) if eta is None
                else check_certificate(CL, Pcert, eta, decay=decay))
        if not cert.verified:
            raise SynthesisError("passivesyn: the Riccati gain fails the exact "
                                 "check: " + "; ".join(cert.failures),
                                 "not_verified", cert.figures())
        return _finish_riccati(plant, gains, Pcert, CL, cert, cert.eta, e,
                               decay, form, report)
```

   where `_finish_riccati` is `_finish` with `X = inv(P_k)`, `Y = K_k X_k`
   (so `K.result.X/Y` keep their meaning). `lmi.check_solver` must accept
   `'RICCATI'` (it is not a cvxpy solver).

3. Tests to add with it: the Riccati and LMI maxima agree on the seeded
   grid of tests/test_synthesis.py (as §1b does here); the scalar
   `x⁺ = 2x + u` at actuator loss 0.24 (feasible) / 0.26 (SynthesisError)
   through the new route; every returned gain passes `check_certificate`.

Measured gain (§2b against §2a, same run): at n = 32, N = 4 the prototype
with η maximised is one to two orders of magnitude faster than one
Clarabel iteration, and at n = 64 it is the only route that maximises η.

Known limit of the prototype: near the supremum the iteration converges
slowly (sublinearly), so the bisection counts a level that has not
converged after 3000 sweeps as infeasible (conservative; the result is
still certified). A Newton (Kleinman-type) step on the same Riccati
operator would converge quadratically; not needed for the target.

### 7.2 cvxpy compile time: build once with Parameters

§1 flags every small case (n = 4) where cvxpy's compilation is more than a
fifth of the total — there it is most of it. §2c measures the fix: with the
η target, the objective weight and the margin as `cvxpy.Parameter`s (DPP),
the first compile costs about the same and every later solve of the same
model compiles in a few milliseconds. `passivesyn`'s retry loop
(`RETRIES`: maximise, then feasibility at 1e-3 and 1e-2 below, with a
100× margin) rebuilds and recompiles the model on every attempt; an η sweep
by a user does the same. Proposed change in `lmi.synthesis_model`: always
create `eta = cp.Variable()` with the constraint `eta >= target` and the
objective `cp.Maximize(weight * eta)` (weight 1: maximise, 0: feasibility),
and `eps = cp.Parameter(nonneg=True)` in `<< -eps * I`; `passivesyn` then
builds the model once and only sets `target.value`, `weight.value`,
`eps.value` per attempt (the prototype is `param_model` in
benchmarks/bench_synthesis.py). At n ≥ 16 the solver dominates and the gain
is small; at n = 4 it removes most of the time of every retry.

### 7.3 The four-row form is not 4× slower: Clarabel already exploits it

§1 and §1b: with Clarabel's default chordal decomposition, the paper form's
mutually-zero mode rows are split off, so both forms become cliques of side
2n + m1 (four per phase in the paper form, two in the merged one); the
measured paper/merged ratio is the 1.5–5× of §1 (growing with n,
shrinking with N), not the
(5/3)⁶ ≈ 21× of a dense factorisation. With chordal decomposition off
(§1b) the ratio is larger, as the dense count predicts. The merged form is
still the right default; the 4× target is missed at the sizes where the
ratio is below 4, for this reason, not because the merge does not work.
A further reduction is possible only by formulation (e.g. the Riccati
route above), not by the merge.

### 7.4 Passivity index of a given system (loss-free and lossy)

§5: at n = 4 and 16 the package is within a small factor of
`control.get_input_ff_index` and agrees with it and with the KYP frequency
test to ~2e-6 relative, with an exactly checked certificate. From n = 32 on
Clarabel is an order of magnitude slower than control's cvxopt code,
because the analysis LMI's constraint matrix is dense (every entry of AᵀPA
depends on every Pᵢⱼ) and Clarabel factors the whole KKT system; at
n = 64 it did not finish in the capped 60 s (a development run took 292 s,
against 23 s for control). `solver='CVXOPT'` through cvxpy is no way out:
it fails with `solver_error` at n = 32 and 64 (control's own cvxopt call,
which builds the LMI basis itself, works). The Riccati iteration without a
gain (`riccati_ff_index` in the prototype) needs no solver; at n = 64 it is
faster than control's cvxopt, but near the supremum it converges slowly, so
its certified value is 1e-5 to 2e-4 (relative) low, and at small n it is
slower than the LMI. Proposed change in `passivity.passivity_certificate`
(not prototyped beyond `riccati_ff_index`): above n ≈ 24, for a loss-free
N = 1 system take the KYP frequency value ν (`frequency_ff_index`, exact
up to its grid refinement) as the target and produce the certificate with
one Riccati run at η = ν(1 − 1e-6), no bisection, then `check_certificate`
as now; for lossy or periodic systems, the bisected iteration. Either way
no interior-point solve of an n(n+1)/2-variable dense LMI.

### 7.5 simulate against the forced_response loop

§4: `simulate` is tens of times faster than both baselines at n = 4 but
only 6–10 times at n = 32 (the ratios moved by up to 2× between our
full runs on the shared machine; §4 interleaves the routes to limit
that). The 50× target is missed at n = 32 because the
baselines' cost per trial-step is Python call overhead, independent of n
(python-control steps a discrete system in a Python loop), while
`simulate` is bound by arithmetic and by memory traffic that grows with n:
it returns every state, output and input of every trial
(n + p + m floats per trial-step; 1.15 GB for 20 000 trials × 200 steps at
n = 32). Profiling (cProfile, development) shows half of the time at
n = 32 in `simulate._store`, the `transpose(2, 0, 1)` copy from the chunk
layout (trial, time, signal) into the result's (signal, trial, time): an
innermost-axis swap at ≈ 15 ns per element. A prototype (development only, not
kept) that keeps chunks as (trial, signal, time) so that the final copy keeps time innermost
(≈ 2 ns per element) gained only 1.06–1.28× overall, because the per-step
write then becomes strided; not worth the change. The ensemble functions
(`step_response` etc. with `quantiles=()`) do not store every path and are
the right tool for many trials.
'''
