//! The hot path allocates nothing: after a first solve has sized the workspace, solving a problem
//! of the same size again performs no heap allocation, for every variant (a counting global
//! allocator watches).

mod common;

use pivotsim_server::solver::{Solver, SolverOptions, Variant};

#[path = "support/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::allocations_during;

#[test]
fn second_solve_allocates_nothing() {
    let plain = common::banded_problem(300, 10, 3, 0.5);
    let friction = common::random_problem(60, 7, true, 0.1, 1.0);
    // Paper-like islands exercise the projected-Newton safeguard and the coupled Newton update;
    // Confeti (semidefinite) the proximal mode.
    let data = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let extreme =
        pivotsim_server::solver::io::read_mlcp_file(&data.join("scene-shaped/scene-extreme200.txt")).unwrap();
    let confeti =
        pivotsim_server::solver::io::read_mlcp_file(&data.join("siconos/Confeti-ex13-Fc3D-SBM.txt")).unwrap();
    for p in [&plain, &friction, &extreme, &confeti] {
        for v in Variant::ALL {
            let mut s = Solver::new(SolverOptions { variant: v, max_steps: 1000, ..Default::default() });
            let mut lam = vec![0.0; p.n()];
            let first = allocations_during(|| {
                s.solve(p, &mut lam);
            });
            assert!(first > 0, "{v}: the first solve must size the workspace");
            let mut steps = 0;
            let second = allocations_during(|| steps = s.solve(p, &mut lam).pivot_steps);
            assert_eq!(second, 0, "{v}: {second} allocations in the second solve ({steps} steps)");
        }
    }
}

/// The direct coupled Newton point (`bpp/coupled.rs`: one envelope LU of the coupled matrix) and
/// its GMRES fallback allocate nothing once warm either: the winch's sliding chain, warm, where
/// many friction rows follow their normal impulses.
#[test]
fn direct_coupled_points_allocate_nothing_once_warm() {
    let data = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/corpus");
    let p = pivotsim_server::solver::io::read_mlcp_file(&data.join("winch-hard00-step000585-island0.txt"))
        .unwrap();
    for coupled_lu in [Some(true), None, Some(false)] {
        let opts = SolverOptions { variant: Variant::Auto, max_steps: 100, coupled_lu, ..Default::default() };
        let mut s = Solver::new(opts);
        let mut lam = vec![0.0; p.n()];
        s.solve(&p, &mut lam);
        let mut points = 0;
        let second = allocations_during(|| points = s.solve(&p, &mut lam).coupled_lu);
        assert_eq!(second, 0, "{coupled_lu:?}: {second} allocations in the second solve");
        if coupled_lu == Some(true) {
            assert!(points > 0, "the direct coupled point was not exercised");
        }
    }
}
