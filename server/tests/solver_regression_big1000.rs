//! A cold, 1,000-row scene-shaped island (`tests/data/regressions/scene-big1000-regressed.txt`:
//! 173 bodies, 97 cable links lying on the ground, mass ratio 1e4, compliance 1e-8, μ = 1) that
//! every exact variant solved until `f1fac5a` and none did after it (relative residual 4e-5 after
//! 100,000 pivot steps, 49,156 of them semismooth Newton steps cycling with the outer friction
//! iteration).
//!
//! What it pins down: a cold solve switches to the interior point method after 3 pivot steps; on
//! this island both interior point runs stall far from a solution, and the pivoting must then go on
//! *exactly where it stopped* — its `λ`, index set, friction bounds frozen at the first all-free
//! solve, its loop's progress counters and best residual. Resuming instead with the bounds
//! re-frozen at the intermediate iterate of step 3 and fresh counters (what `f1fac5a` did) put the
//! outer friction iteration on a path that cycles for ever. Pivoting alone solves the island in 75
//! steps; a failed switch may add its own iterations and nothing else.
//!
//! Judged by an independent recomputation of the natural-map residual (`solver_common`) and
//! against the reference solution filed with the problem (residual 2e-17).

mod solver_common;

use std::path::PathBuf;

use pivotsim_server::solver::{SolveStatus, Solver, SolverOptions, Variant, io};
use solver_common::natural_map_residual;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/regressions").join(name)
}

fn problem_and_reference() -> (pivotsim_server::solver::Mlcp, Vec<f64>) {
    let p = io::read_mlcp_file(&data("scene-big1000-regressed.txt")).expect("regression problem");
    let text = std::fs::read_to_string(data("scene-big1000-regressed.sol")).expect("reference solution");
    let reference = io::parse_solution(&text).expect("reference solution parses");
    assert_eq!(reference.len(), p.n());
    assert!(p.lambda0().is_none(), "the regression is a cold solve");
    (p, reference)
}

fn solve(
    p: &pivotsim_server::solver::Mlcp,
    opts: SolverOptions,
) -> (Vec<f64>, pivotsim_server::solver::SolveStats) {
    let mut s = Solver::new(opts);
    let mut lam = vec![0.0; p.n()];
    let st = s.solve(p, &mut lam).clone();
    (lam, st)
}

#[test]
fn the_reference_solves_the_problem() {
    // The checker and the reference agree before either judges the solver.
    let (p, reference) = problem_and_reference();
    let (_, rel) = natural_map_residual(&p, &reference);
    assert!(rel <= 1e-15, "reference residual {rel:e}");
}

#[test]
fn big1000_converges_with_every_exact_variant_and_matches_the_reference() {
    let (p, reference) = problem_and_reference();
    let scale = reference.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    for v in Variant::EXACT {
        let (lam, st) = solve(&p, SolverOptions { variant: v, max_steps: 1000, ..Default::default() });
        let (_, rel) = natural_map_residual(&p, &lam);
        let diff = lam.iter().zip(&reference).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        println!(
            "{v}: {} in {} steps ({} interior point iterations in {} runs), residual {rel:.1e}, \
             max |λ − λ_ref| / ‖λ_ref‖ {:.1e}",
            st.status.name(),
            st.pivot_steps,
            st.ipm_iterations,
            st.ipm_runs,
            diff / scale
        );
        assert_eq!(
            st.status,
            SolveStatus::Converged,
            "{v}: {} after {} steps",
            st.status.name(),
            st.pivot_steps
        );
        assert!(rel <= 1e-9, "{v}: independent residual {rel:e}");
        assert!(diff <= 1e-6 * scale, "{v}: {:.1e} from the reference", diff / scale);
    }
}

#[test]
fn a_failed_interior_point_switch_costs_only_its_own_iterations() {
    let (p, _) = problem_and_reference();
    for v in [Variant::Skyline, Variant::Auto] {
        let alone =
            SolverOptions { variant: v, max_steps: 1000, ipm_cold_after: usize::MAX, ..Default::default() };
        let (_, st_alone) = solve(&p, alone);
        let (_, st) = solve(&p, SolverOptions { variant: v, max_steps: 1000, ..Default::default() });
        assert_eq!(st_alone.status, SolveStatus::Converged, "{v} alone");
        // Both runs of the interior point method stall here (no crossover trial): what is left
        // is the pivoting's own path.
        assert_eq!(st.ipm_runs, 2, "{v}: the switch no longer fails here; pick another witness");
        assert_eq!(st.status, SolveStatus::Converged, "{v}");
        assert!(
            st.pivot_steps <= st_alone.pivot_steps + st.ipm_iterations,
            "{v}: {} steps with the switch, {} alone + {} interior point iterations",
            st.pivot_steps,
            st_alone.pivot_steps,
            st.ipm_iterations
        );
    }
}
