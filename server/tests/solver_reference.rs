//! Every exact solver variant against independent references: brute-force enumeration of index
//! sets on small boxed LCPs, agreement between variants on random SPD problems up to m = 1000, and
//! a property test on random small problems. The solution of a boxed LCP with SPD `A` and fixed
//! bounds is unique, so every exact variant must return the same `λ`.

mod common;

use common::{banded_problem, random_problem};
use pivotsim_server::solver::reference::{Enumerated, enumerate_solutions};
use pivotsim_server::solver::{Mlcp, OrderingKind, SolveStatus, Solver, SolverOptions, Variant};
use proptest::prelude::*;

fn solve(p: &Mlcp, variant: Variant, max_steps: usize) -> (Vec<f64>, pivotsim_server::solver::SolveStats) {
    let mut s = Solver::new(SolverOptions { variant, max_steps, ..Default::default() });
    let mut lam = vec![0.0; p.n()];
    let st = s.solve(p, &mut lam).clone();
    (lam, st)
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

#[test]
fn exact_variants_match_enumeration_without_friction() {
    for seed in 0..40 {
        let n = 2 + (seed as usize % 9);
        let p = random_problem(n, seed, false, 0.5, 0.2);
        let sols = enumerate_solutions(&p, 1e-9);
        assert_eq!(sols.len(), 1, "seed {seed}: SPD boxed LCP must have one solution");
        for v in Variant::EXACT {
            let (lam, st) = solve(&p, v, 200);
            assert_eq!(st.status, SolveStatus::Converged, "seed {seed} {v}");
            let d = max_diff(&lam, &sols[0].lambda);
            assert!(
                d < 1e-9 * (1.0 + sols[0].lambda.iter().fold(0.0f64, |a, x| a.max(x.abs()))),
                "seed {seed} {v}: {d}"
            );
        }
    }
}

/// Small random problems with friction and their enumerated solutions (seed, problem, solutions).
fn friction_problems() -> Vec<(u64, Mlcp, Vec<Enumerated>)> {
    let mut out = Vec::new();
    for seed in 100..160 {
        let n = 3 + (seed as usize % 6);
        let p = random_problem(n, seed, true, 0.3, 0.5);
        if !p.has_friction() {
            continue;
        }
        let sols = enumerate_solutions(&p, 1e-9);
        if !sols.is_empty() {
            out.push((seed, p, sols));
        }
    }
    out
}

#[test]
fn exact_variants_find_an_enumerated_solution_with_friction() {
    let mut checked = 0;
    for (seed, p, sols) in friction_problems() {
        for v in Variant::EXACT {
            let (lam, st) = solve(&p, v, 1000);
            assert_eq!(st.status, SolveStatus::Converged, "seed {seed} {v} residual {}", st.residual_rel);
            assert!(st.residual_rel <= 1e-9, "seed {seed} {v}: {}", st.residual_rel);
            let nearest = sols.iter().map(|s| max_diff(&lam, &s.lambda)).fold(f64::INFINITY, f64::min);
            assert!(nearest < 1e-7, "seed {seed} {v}: no enumerated solution within {nearest}");
        }
        checked += 1;
    }
    assert!(checked >= 20, "only {checked} friction problems checked");
}

/// The interior point method (`ipm.rs`) on its own — first on cold solves, and switched to at
/// once on warm ones — lands on an enumerated solution of the friction-coupled problem, with its
/// iterations counted as pivot steps.
#[test]
fn interior_point_finds_an_enumerated_solution_with_friction() {
    let mut checked = 0;
    for (seed, p, sols) in friction_problems() {
        let n = p.n();
        let warm = p.clone().with_warm_start(Some(vec![0.0; n]), None).unwrap();
        for (kind, q, opts) in [
            ("cold", &p, SolverOptions { ipm_cold_after: 0, max_steps: 1000, ..Default::default() }),
            ("warm", &warm, SolverOptions { ipm_after: 0, max_steps: 1000, ..Default::default() }),
        ] {
            let mut s = Solver::new(opts);
            let mut lam = vec![0.0; n];
            let st = s.solve(q, &mut lam).clone();
            // One run, or two when the first stalls and its crossover trial fails (a restart from
            // the second start, `ipm.rs`).
            assert!(
                (1..=2).contains(&st.ipm_runs),
                "seed {seed} {kind}: {} interior point runs",
                st.ipm_runs
            );
            assert!(st.ipm_iterations >= 1 && st.pivot_steps >= st.ipm_iterations, "seed {seed} {kind}");
            assert_eq!(st.status, SolveStatus::Converged, "seed {seed} {kind}: residual {}", st.residual_rel);
            let nearest = sols.iter().map(|s| max_diff(&lam, &s.lambda)).fold(f64::INFINITY, f64::min);
            assert!(nearest < 1e-7, "seed {seed} {kind}: no enumerated solution within {nearest}");
        }
        checked += 1;
    }
    assert!(checked >= 20, "only {checked} friction problems checked");
}

#[test]
fn variants_agree_on_random_spd_problems_up_to_1000() {
    for (n, seed) in [(50, 1), (200, 2), (500, 3), (1000, 4)] {
        let p = banded_problem(n, 12, seed, 0.3);
        let (reference, st) = solve(&p, Variant::Full, 1000);
        assert_eq!(st.status, SolveStatus::Converged, "n={n}");
        assert!(st.tight > 0, "n={n}: the test needs tight variables");
        let scale = reference.iter().fold(1.0f64, |a, x| a.max(x.abs()));
        for v in Variant::EXACT {
            let (lam, st) = solve(&p, v, 1000);
            assert_eq!(st.status, SolveStatus::Converged, "n={n} {v}");
            let d = max_diff(&lam, &reference);
            assert!(d <= 1e-9 * scale, "n={n} {v}: differs from full by {d}");
            if v.uses_envelope() {
                assert!(st.bandwidth_after < st.bandwidth_before, "n={n} {v}: RCM did not reduce bandwidth");
            }
        }
    }
}

#[test]
fn orderings_give_the_same_solution() {
    let p = banded_problem(300, 8, 9, 0.4);
    let (reference, _) = solve(&p, Variant::Full, 1000);
    for ordering in [OrderingKind::Natural, OrderingKind::CuthillMcKee, OrderingKind::ReverseCuthillMcKee] {
        let mut s = Solver::new(SolverOptions {
            variant: Variant::Skyline,
            ordering,
            max_steps: 1000,
            ..Default::default()
        });
        let mut lam = vec![0.0; p.n()];
        assert_eq!(s.solve(&p, &mut lam).status, SolveStatus::Converged);
        assert!(max_diff(&lam, &reference) < 1e-9);
    }
}

#[test]
fn warm_start_from_the_solution_takes_one_step() {
    let p = banded_problem(200, 10, 5, 0.3);
    let mut s = Solver::new(SolverOptions { variant: Variant::Auto, ..Default::default() });
    let mut lam = vec![0.0; p.n()];
    let cold = s.solve(&p, &mut lam).pivot_steps;
    let warm = p.clone().with_warm_start(Some(lam.clone()), Some(s.index_set().to_vec())).unwrap();
    let mut lam2 = vec![0.0; p.n()];
    let st = s.solve(&warm, &mut lam2);
    assert_eq!(st.status, SolveStatus::Converged);
    assert_eq!(st.pivot_steps, 1, "cold start took {cold}");
    assert!(max_diff(&lam, &lam2) < 1e-10);
}

#[test]
fn deletion_error_is_small() {
    let p = banded_problem(400, 20, 11, 0.5);
    for v in [Variant::Downdate, Variant::Skyline, Variant::Auto] {
        let mut s = Solver::new(SolverOptions {
            variant: v,
            measure_deletion_error: true,
            max_steps: 1000,
            ..Default::default()
        });
        let mut lam = vec![0.0; p.n()];
        let st = s.solve(&p, &mut lam);
        if st.deletions > 0 {
            let e = st.deletion_error.expect("measured");
            assert!(e <= 1e-11, "{v}: relative deletion error {e}");
            if v != Variant::Downdate {
                let b = st.deletion_backward_error.expect("measured on the envelope");
                assert!(b <= 1e-14, "{v}: backward error {b}");
            }
        }
    }
}

#[test]
fn step_cap_returns_the_best_iterate_with_a_status() {
    let p = banded_problem(300, 10, 21, 0.8);
    let (_, full) = solve(&p, Variant::Auto, 1000);
    assert!(full.pivot_steps > 2, "needs a problem with several pivot steps");
    let (lam, st) = solve(&p, Variant::Auto, 1);
    assert_eq!(st.status, SolveStatus::MaxSteps);
    assert!(lam.iter().all(|x| x.is_finite()));
    // The reported residual is that of the returned λ.
    let mut w = vec![0.0; p.n()];
    let (r, _) = p.natural_residual(&lam, &mut w);
    assert!((r - st.residual).abs() <= 1e-12 * (1.0 + r));
}

#[test]
fn wrong_output_length_is_reported_not_a_panic() {
    let p = random_problem(5, 1, false, 0.5, 0.2);
    let mut s = Solver::new(SolverOptions::default());
    let mut lam = vec![0.0; 4];
    assert_eq!(s.solve(&p, &mut lam).status, SolveStatus::Empty);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]
    #[test]
    fn random_small_boxed_problems(seed in 0u64..1_000_000, n in 1usize..8) {
        let p = random_problem(n, seed, false, 0.4, 0.3);
        let sols = enumerate_solutions(&p, 1e-9);
        prop_assert_eq!(sols.len(), 1);
        for v in [Variant::Full, Variant::Skyline, Variant::Auto, Variant::Incremental] {
            let (lam, st) = solve(&p, v, 200);
            prop_assert_eq!(st.status, SolveStatus::Converged);
            prop_assert!(max_diff(&lam, &sols[0].lambda) < 1e-8);
        }
    }
}

#[test]
fn murty_fallback_reaches_the_same_solution() {
    use pivotsim_server::solver::Fallback;
    for (n, seed) in [(120, 31), (300, 32)] {
        let p = banded_problem(n, 10, seed, 0.6);
        let (reference, _) = solve(&p, Variant::Full, 1000);
        for v in [Variant::Full, Variant::Skyline, Variant::Auto] {
            let mut s = Solver::new(SolverOptions {
                variant: v,
                fallback: Fallback::Murty,
                murty_after: 0,
                max_steps: 5000,
                ..Default::default()
            });
            let mut lam = vec![0.0; p.n()];
            let st = s.solve(&p, &mut lam);
            assert_eq!(st.status, SolveStatus::Converged, "n={n} {v}");
            assert!(max_diff(&lam, &reference) < 1e-9, "n={n} {v}");
        }
    }
}

#[test]
fn a_new_problem_with_the_same_pattern_reuses_the_ordering_and_solves_correctly() {
    let p1 = banded_problem(250, 9, 41, 0.4);
    // Same pattern, other values: scale the matrix and change b.
    let n = p1.n();
    let mut trip = Vec::new();
    for i in 0..n {
        let (cols, vals) = p1.a().row(i);
        for (&j, &v) in cols.iter().zip(vals) {
            trip.push((i, j, if i == j { 2.0 * v + 0.1 } else { 2.0 * v }));
        }
    }
    let a2 = pivotsim_server::solver::SymCsr::from_triplets(n, &trip).unwrap();
    let b2: Vec<f64> = p1.b().iter().map(|x| -0.5 * x + 0.1).collect();
    let p2 = Mlcp::new(a2, b2, p1.lo().to_vec(), p1.hi().to_vec(), p1.findex().to_vec()).unwrap();
    for v in [Variant::Skyline, Variant::Auto, Variant::Incremental] {
        let mut s = Solver::new(SolverOptions { variant: v, max_steps: 1000, ..Default::default() });
        let mut lam = vec![0.0; n];
        assert!(!s.solve(&p1, &mut lam).pattern_reused);
        let st = s.solve(&p2, &mut lam).clone();
        assert!(st.pattern_reused, "{v}");
        let (fresh, _) = solve(&p2, v, 1000);
        assert_eq!(st.status, SolveStatus::Converged);
        assert!(max_diff(&lam, &fresh) < 1e-12, "{v}");
    }
}

#[test]
fn generated_contact_islands_converge_with_every_exact_variant() {
    // Chains of bodies with ball joints and frictional ground contacts (the bench's generator),
    // including the ones whose outer friction iteration cycles between two index sets.
    use pivotsim_server::solver::generate::contact_like;
    for (m, seed, ratio) in [(200, 3, 6_300.0), (430, 5, 6_300.0), (430, 7, 20_000.0), (430, 8, 6_300.0)] {
        let p = contact_like(m, seed, ratio);
        assert!(p.has_friction());
        for v in Variant::EXACT {
            let (lam, st) = solve(&p, v, 1000);
            println!(
                "m={} seed={seed} {v}: {} steps {} newton {} residual {:.1e}",
                p.n(),
                st.status.name(),
                st.pivot_steps,
                st.newton_steps,
                st.residual_rel
            );
            assert_eq!(st.status, SolveStatus::Converged, "m={m} seed={seed} {v}");
            let mut w = vec![0.0; p.n()];
            let (_, rel) = p.natural_residual(&lam, &mut w);
            assert!(rel <= 1e-9, "m={m} seed={seed} {v}: {rel:e}");
        }
    }
}

/// `auto` factors `L₀` only when its cost model first chooses deletions from it: a warm start that
/// is the solution needs a pivot step or two (a friction update may follow), which refactors of
/// `A_FF ⊕ I` serve without `L₀`, and the answer solves the problem (independent residual).
#[test]
fn auto_factors_l0_only_when_it_deletes_from_it() {
    let mut checked = 0;
    for seed in 0..12 {
        let mut p = pivotsim_server::solver::generate::contact_like(200, seed, 1e3);
        // The reference solve pivots alone: its answer is a vertex of the pivoting (an interior
        // point answer that its crossover did not turn into one is a poorer warm start).
        let pivoting = SolverOptions {
            variant: Variant::Skyline,
            max_steps: 1000,
            ipm_cold_after: usize::MAX,
            ..Default::default()
        };
        let mut s = Solver::new(pivoting);
        let mut lam = vec![0.0; p.n()];
        s.solve(&p, &mut lam);
        let mut s = Solver::new(pivoting);
        let mut l = vec![0.0; p.n()];
        s.solve(&p, &mut l);
        let index = s.index_set().to_vec();
        if !index.iter().any(|s| s.is_tight()) {
            continue;
        }
        p.set_warm_start(Some(&lam), Some(&index)).expect("warm start");
        let (warm, st) = solve(&p, Variant::Auto, 35);
        assert_eq!(st.status, SolveStatus::Converged, "seed {seed}");
        assert!(st.pivot_steps <= 2, "seed {seed}: {} steps from the solution", st.pivot_steps);
        assert_eq!(st.auto_choices[0], 0, "seed {seed}: {:?}: deleted from L0", st.auto_choices);
        assert!(!st.l0_factored, "seed {seed}: L0 factored though never used");
        assert!(st.auto_choices[2] >= 1, "seed {seed}: {:?}", st.auto_choices);
        // Friction makes the solution non-unique in general: judged by its own residual.
        let mut w = vec![0.0; p.n()];
        let (_, rr) = p.natural_residual(&warm, &mut w);
        assert!(rr <= 1e-9, "seed {seed}: residual {rr:e}");
        checked += 1;
    }
    assert!(checked >= 6, "only {checked} problems had tight rows");
}

/// A solve reports its thread's CPU time beside its wall time: positive, and no more than the
/// wall time (one thread cannot run longer than the clock on the wall; 20 µs for the two clocks'
/// granularity).
#[test]
fn a_solve_reports_its_cpu_time_within_its_wall_time() {
    for variant in [Variant::Full, Variant::Auto, Variant::Pgs] {
        let p = random_problem(300, 7, false, 0.05, 1.0);
        let (_, st) = solve(&p, variant, 100);
        assert!(st.cpu_us > 0.0, "{variant:?}: cpu {}", st.cpu_us);
        assert!(
            st.cpu_us <= st.total_us + 20.0,
            "{variant:?}: cpu {} µs, wall {} µs",
            st.cpu_us,
            st.total_us
        );
    }
}

/// The profile numbers a solve reports are those of its ordering, computed independently here
/// from the input matrix and the same (deterministic) reverse Cuthill–McKee permutation.
#[test]
fn reported_bandwidth_and_envelope_are_those_of_the_ordering() {
    use pivotsim_server::solver::ordering::{self, OrderingWorkspace};
    for (n, bw, seed) in [(120, 6, 31), (300, 12, 32)] {
        let p = banded_problem(n, bw, seed, 0.3);
        let (_, st) = solve(&p, Variant::Auto, 100);
        let (mut perm, mut inv) = (Vec::new(), Vec::new());
        OrderingWorkspace::new().order(p.a(), OrderingKind::ReverseCuthillMcKee, &mut perm, &mut inv);
        assert_eq!(st.bandwidth_before, ordering::bandwidth(p.a()));
        assert_eq!(st.envelope_before, ordering::envelope(p.a()));
        assert_eq!(st.bandwidth_after, ordering::bandwidth_permuted(p.a(), &inv));
        assert_eq!(st.envelope_after, ordering::envelope_permuted(p.a(), &inv));
        assert!(st.envelope_after < st.envelope_before, "n={n}: the shuffled band came back");
    }
}
